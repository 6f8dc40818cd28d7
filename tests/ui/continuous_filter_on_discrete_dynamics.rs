stateforge::model! {
    /// A model with one mistake: the hybrid EKF integrates `dx/dt`, which a discrete
    /// model does not give.
    pub mod m {
        scalar f32;
        state x1;
        input u;
        output y = x1;
        generate hybrid_ekf;
        dynamics discrete {
            x1 = x1 + u;
        }
    }
}

fn main() {}
