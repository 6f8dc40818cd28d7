stateforge::model! {
    /// An unstable regime and a given gain too small to stabilise it.
    pub mod m {
        scalar f32;
        const Q = 1e-6;
        const R = 1e-4;
        const K1 = 0.05;
        state x1;
        output y = x1;
        generate switched_observer(process_noise = [Q], measurement_noise = [R], k1 = [K1]);
        dynamics discrete {
            x1 = 1.1 * x1 + if x1 > 0.0 { 0.2 * x1 } else { 0.0 };
        }
    }
}

fn main() {}
