stateforge::model! {
    /// A raw identifier cannot name a state.
    pub mod m {
        scalar f32;
        state r#type;
        dynamics discrete {
            r#type = r#type;
        }
    }
}

fn main() {}
