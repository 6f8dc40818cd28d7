stateforge::model! {
    /// A model with one mistake: `hybrid_ekf` treats the estimate's entries as a vector, and
    /// the mounting is a rotation.
    pub mod m {
        scalar f64;
        const TS = 0.01;
        state q, qd;
        param inv_m;
        param
            /// mounting of the sensor
            #[allow(unused)]
            mount: Rot3;
        input u;
        output y = q;
        generate hybrid_ekf;
        dynamics continuous(euler, dt = TS, substeps = 100) {
            der(q) = qd;
            der(qd) = inv_m * (u - 500.0 * q - 0.1 * qd);
        }
    }
}

fn main() {}
