stateforge::model! {
    /// A model with one mistake: a prescribed degree of stability is at least 0.
    pub mod m {
        scalar f32;
        const TS = 0.01;
        state x1;
        input u;
        output y = x1;
        generate continuous_ekf(alpha = -1.0);
        dynamics continuous(rk4, dt = TS) {
            der(x1) = -x1 + u;
        }
    }
}

fn main() {}
