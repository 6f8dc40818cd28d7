stateforge::model! {
    /// A sensor of two outputs with its own gate, and a vector output's own sensor declared
    /// for its gate (`sensor mag(..) = [mag]`, named as the output): each update is gated
    /// at its own chi-square quantile, the joint one at the filter's.
    pub mod m {
        scalar f64;
        state v: Vec3, a, b;
        output mag = v, pair_a = a, pair_b = b;
        sensor mag(gate = 16.27) = [mag];
        sensor pair(gate = 13.82) = [pair_b, pair_a];
        generate ekf(gate = 22.46);
        dynamics discrete {
            v = v;
            a = a;
            b = b;
        }
    }
}

fn main() {
    let r: [[f64; 5]; 5] = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j))));
    let ekf = m::Ekf::new(&[0.0; 5], &r, &r, &r).unwrap();
    assert_eq!(ekf.mag_innovation_gate(), 16.27);
    assert_eq!(ekf.pair_innovation_gate(), 13.82);
    assert_eq!(ekf.innovation_gate(), 22.46);
    assert_eq!(ekf.mag_noise(), [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    assert_eq!(ekf.pair_noise(), [[1.0, 0.0], [0.0, 1.0]]);
}
