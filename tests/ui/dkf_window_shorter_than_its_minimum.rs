stateforge::model! {
    /// The cantilever's window transform needs 5 output samples: a window of 4 is
    /// reported under its length, with the minimum to write.
    pub mod m {
        scalar f32;
        const TS = 0.015;
        state x1, x2;
        param x3, x4, x5;
        input u;
        output y = x1;
        generate dkf(eta = 0.5, window = 4);
        dynamics discrete {
            x1 = x1 + TS * x2;
            x2 = TS * x1 * x3 + (1.0 + TS * x4) * x2 + TS * x5 * u;
        }
    }
}

fn main() {}
