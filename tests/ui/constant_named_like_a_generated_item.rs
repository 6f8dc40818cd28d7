stateforge::model! {
    /// `ltv_model` is generated for the DKF.
    pub mod m {
        scalar f32;
        const ltv_model = 1.0;
        state x1;
        param a;
        output y = x1;
        dynamics discrete {
            x1 = a * x1;
        }
        generate dkf;
    }
}

fn main() {}
