//! The error bounds the crate documents, asserted on millions of sampled inputs over every
//! range a model can feed (tiny, subnormal, near multiples of pi/2, large, huge, NaN,
//! infinities, signed zeros). `cargo xtask math-ulps` measures the bounds over every `f32`
//! (sin 1.255, cos 1.247, tan 3.043, exp 0.990, ln 0.829, tanh 1.330, atan2 2.064 on its
//! grid and random pairs; sqrt is correctly rounded): the asserted bounds are those, rounded up.

use stateforge_math::f32 as m;

#[path = "common/ulp.rs"]
mod ulp;
use ulp::ulp_error;

#[path = "common/random.rs"]
mod random;
use random::Random;

impl Random {
    /// A random bit pattern: every f32, NaNs and infinities included.
    fn any(&mut self) -> f32 {
        f32::from_bits(self.next() as u32)
    }

    /// Uniform in `[low, high]`.
    fn uniform(&mut self, low: f32, high: f32) -> f32 {
        let unit = (self.next() >> 40) as f32 / (1u64 << 24) as f32;
        low + (high - low) * unit
    }
}

/// Edge inputs every function sees.
const EDGES: [f32; 14] = [
    0.0,
    -0.0,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    f32::MIN_POSITIVE,
    -f32::MIN_POSITIVE,
    1e-45,
    -1e-45,
    1e-40,
    f32::MAX,
    f32::MIN,
    1.0,
    -1.0,
];

/// Asserts `ours` within `bound` ulps of `reference` on `inputs`; returns the largest error.
fn assert_within(
    name: &str,
    bound: f64,
    inputs: impl Iterator<Item = f32>,
    ours: impl Fn(f32) -> f32,
    reference: impl Fn(f64) -> f64,
) -> f64 {
    let mut worst = 0.0_f64;
    for x in inputs {
        let e = ulp_error(ours(x), reference(f64::from(x)));
        assert!(
            e <= bound,
            "{name}({x:e}) = {:e}: {e} ulp > {bound}",
            ours(x)
        );
        worst = worst.max(e);
    }
    worst
}

/// Around the multiples of pi/2 up to [`m::TRIG_ACCURATE`], where the reduced argument
/// is smallest: the nearest f32 to `k pi/2` and its neighbours.
fn near_multiples_of_pi_2() -> impl Iterator<Item = f32> {
    (-4096_i32..=4096).flat_map(|k| {
        let centre = (f64::from(k) * std::f64::consts::FRAC_PI_2) as f32;
        (-8_i32..=8).map(move |d| f32::from_bits(centre.to_bits().wrapping_add_signed(d)))
    })
}

fn trig_inputs(random: &mut Random) -> Vec<f32> {
    let mut inputs: Vec<f32> = EDGES.to_vec();
    inputs.extend(near_multiples_of_pi_2());
    inputs.extend((0..1_000_000).map(|_| random.any()));
    inputs.extend((0..1_000_000).map(|_| random.uniform(-20.0, 20.0)));
    inputs.extend((0..200_000).map(|_| random.uniform(-1e-3, 1e-3)));
    inputs
}

#[test]
fn sine_and_cosine_within_their_bound_and_bounded_beyond() {
    let mut random = Random(1);
    let inputs = trig_inputs(&mut random);
    let accurate = || {
        inputs
            .iter()
            .copied()
            .filter(|x| x.abs() <= m::TRIG_ACCURATE || !x.is_finite())
    };
    assert_within("sin", 1.26, accurate(), m::sin, libm::sin);
    assert_within("cos", 1.26, accurate(), m::cos, libm::cos);
    assert_within("tan", 3.05, accurate(), m::tan, libm::tan);
    for x in inputs.iter().copied().filter(|x| x.is_finite()) {
        let (s, c) = m::sin_cos(x);
        assert!(
            s.abs() <= 1.0 && c.abs() <= 1.0,
            "sin_cos({x:e}) = ({s}, {c})"
        );
        assert_eq!(
            (s.to_bits(), c.to_bits()),
            (m::sin(x).to_bits(), m::cos(x).to_bits())
        );
    }
    // The sign of a zero sine is not kept (see `sin_cos`).
    assert_eq!(m::sin(-0.0), 0.0);
    assert_eq!(m::cos(-0.0), 1.0);
}

#[test]
fn exponential_within_its_bound_with_overflow_and_underflow() {
    let mut random = Random(2);
    let mut inputs: Vec<f32> = EDGES.to_vec();
    inputs.extend((0..1_000_000).map(|_| random.any()));
    inputs.extend((0..1_000_000).map(|_| random.uniform(-110.0, 90.0)));
    inputs.extend((0..200_000).map(|_| random.uniform(-104.0, -87.0)));
    inputs.extend((0..200_000).map(|_| random.uniform(-1e-6, 1e-6)));
    inputs
        .extend((-64..=64).map(|d| f32::from_bits(88.72284_f32.to_bits().wrapping_add_signed(d))));
    assert_within("exp", 0.99, inputs.into_iter(), m::exp, libm::exp);
    assert_eq!(m::exp(89.0), f32::INFINITY);
    assert_eq!(m::exp(-104.0), 0.0);
    assert!(m::exp(-100.0) > 0.0 && m::exp(-100.0) < f32::MIN_POSITIVE);
}

#[test]
fn logarithm_within_its_bound_with_its_edges() {
    let mut random = Random(3);
    let mut inputs: Vec<f32> = EDGES.to_vec();
    inputs.extend((0..1_000_000).map(|_| random.any()));
    inputs.extend((0..1_000_000).map(|_| random.uniform(0.5, 2.0)));
    inputs.extend((0..200_000).map(|_| f32::from_bits(random.next() as u32 & 0x007F_FFFF)));
    assert_within("ln", 0.83, inputs.into_iter(), m::ln, libm::log);
    assert!(m::ln(-1.0).is_nan() && m::ln(f32::NAN).is_nan());
    assert_eq!(m::ln(0.0), f32::NEG_INFINITY);
    assert_eq!(m::ln(-0.0), f32::NEG_INFINITY);
    assert_eq!(m::ln(f32::INFINITY), f32::INFINITY);
    assert_eq!(m::ln(1.0), 0.0);
}

#[test]
fn hyperbolic_tangent_and_square_root_within_their_bounds() {
    let mut random = Random(4);
    let mut inputs: Vec<f32> = EDGES.to_vec();
    inputs.extend((0..1_000_000).map(|_| random.any()));
    inputs.extend((0..1_000_000).map(|_| random.uniform(-10.0, 10.0)));
    assert_within("tanh", 1.33, inputs.iter().copied(), m::tanh, libm::tanh);
    assert_within("sqrt", 0.5, inputs.iter().copied(), m::sqrt, libm::sqrt);
    assert_eq!(m::tanh(-0.0).to_bits(), (-0.0_f32).to_bits());
    assert_eq!(m::tanh(f32::NEG_INFINITY), -1.0);
    assert_eq!(m::sqrt(-0.0).to_bits(), (-0.0_f32).to_bits());
    assert!(m::sqrt(-1.0).is_nan());
}

#[test]
fn arctangent_within_its_bound_in_every_quadrant_and_at_the_edges() {
    let mut random = Random(5);
    let mut worst = 0.0_f64;
    let mut check = |y: f32, x: f32| {
        let e = ulp_error(m::atan2(y, x), libm::atan2(f64::from(y), f64::from(x)));
        assert!(
            e <= ATAN2_BOUND,
            "atan2({y:e}, {x:e}) = {:e}: {e} ulp",
            m::atan2(y, x)
        );
        worst = worst.max(e);
    };
    for &y in &EDGES {
        for &x in &EDGES {
            check(y, x);
        }
    }
    for _ in 0..1_000_000 {
        check(random.any(), random.any());
        check(random.uniform(-10.0, 10.0), random.uniform(-10.0, 10.0));
    }
    assert_eq!(m::atan2(0.0, -0.0), core::f32::consts::PI);
    assert_eq!(m::atan2(-0.0, 0.0).to_bits(), (-0.0_f32).to_bits());
}

/// The largest error of `atan2` measured (`cargo xtask math-ulps atan2`: 2.064).
const ATAN2_BOUND: f64 = 2.07;
