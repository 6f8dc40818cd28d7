stateforge::model! {
    /// A model with one mistake: `lqr` treats the estimate's entries as a vector, and
    /// the attitude is a rotation.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        state
            /// attitude, constant
            attitude: Rot3;
        input u;
        output y = x1;
        generate lqr(horizon = 50, states = [x1, x2], input = u);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = x2 - TS * x1 + TS * u;
            attitude = attitude;
        }
    }
}

fn main() {}
