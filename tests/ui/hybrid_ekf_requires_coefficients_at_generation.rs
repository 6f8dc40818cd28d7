stateforge::model! {
    /// A model with one mistake: the hybrid EKF needs every coefficient when the code is
    /// generated, and the stiffness is known only at run time.
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state q, qd;
        param inv_m;
        input u;
        known stiffness;
        output y = q;
        generate hybrid_ekf;
        dynamics continuous(euler, dt = TS, substeps = 10) {
            der(q) = qd;
            der(qd) = inv_m * (u - stiffness * q - 0.1 * qd);
        }
    }
}

fn main() {}
