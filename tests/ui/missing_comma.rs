stateforge::model! {
    /// Two names without a comma between them: the error is at the second name.
    pub mod m {
        scalar f32;
        state x1 x2;
        dynamics discrete {
            x1 = x1;
            x2 = x2;
        }
    }
}

fn main() {}
