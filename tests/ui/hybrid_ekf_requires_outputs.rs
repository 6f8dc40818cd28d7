stateforge::model! {
    /// A model with one mistake: the hybrid EKF corrects its estimate with measurements,
    /// and the model declares none.
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state q, qd;
        param inv_m;
        input u;
        generate hybrid_ekf;
        dynamics continuous(euler, dt = TS, substeps = 100) {
            der(q) = qd;
            der(qd) = inv_m * (u - 500.0 * q - 0.1 * qd);
        }
    }
}

fn main() {}
