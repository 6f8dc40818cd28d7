stateforge::model! {
    /// A doc comment inside dynamics documents nothing.
    pub mod m {
        scalar f32;
        state x1;
        dynamics discrete {
            /// halves the state
            x1 = 0.5 * x1;
        }
    }
}

fn main() {}
