stateforge::model! {
    /// A model whose constant, equation and last declaration lack their `;`: each error is
    /// under the token the `;` belongs after, all three in one compile.
    pub mod m {
        scalar f32;
        const TS = 0.01
        state x1, x2;
        input u;
        dynamics discrete {
            x1 = x1 + TS * x2
            x2 = x2 + TS * u;
        }
        output y = x1;
        generate ekf
    }
}

fn main() {}
