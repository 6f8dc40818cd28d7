stateforge::model! {
    /// A step that switches on a parameter's sign.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1, x2;
        param k, c;
        input u;
        output y = x1;
        generate dkf;
        dynamics discrete {
            let friction = if c > 0.0 { 1.0 } else { -1.0 };
            x1 = x1 + TS * x2;
            x2 = x2 + TS * (k * x1 + u - friction);
        }
    }
}

fn main() {}
