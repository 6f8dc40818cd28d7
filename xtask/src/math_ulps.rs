//! `cargo xtask math-ulps`: the largest error, in ulps, of each `stateforge_math::f32`
//! function against `libm`'s `f64` function of the same input, over every `f32` input
//! (`atan2`: a dense grid and random pairs). Minutes in a release build; the crate's tests
//! assert the bounds on samples.

use std::sync::atomic::{AtomicU32, Ordering};

// `atan2`'s random pairs come from the crate tests' generator.
#[path = "../../stateforge-math/tests/common/random.rs"]
mod random;
#[path = "../../stateforge-math/tests/common/ulp.rs"]
mod ulp;
use random::Random;
pub use ulp::ulp_error;

/// One function of one argument: its name, ours, the `f64` reference, and the inputs
/// whose errors count (the others are only checked to be of the right kind).
struct Unary {
    name: &'static str,
    ours: fn(f32) -> f32,
    reference: fn(f64) -> f64,
    counts: fn(f32) -> bool,
    /// What an input outside `counts` must give (finite and within [-1, 1], say).
    outside: fn(f32, f32) -> bool,
}

fn accurate_trig(x: f32) -> bool {
    x.abs() <= stateforge_math::f32::TRIG_ACCURATE
}

fn bounded(_: f32, y: f32) -> bool {
    y.is_finite() && y.abs() <= 1.0
}

fn finite(_: f32, y: f32) -> bool {
    y.is_finite()
}

fn never(_: f32, _: f32) -> bool {
    false
}

fn all(_: f32) -> bool {
    true
}

const UNARY: &[Unary] = &[
    Unary {
        name: "sin",
        ours: stateforge_math::f32::sin,
        reference: libm::sin,
        counts: accurate_trig,
        outside: bounded,
    },
    Unary {
        name: "cos",
        ours: stateforge_math::f32::cos,
        reference: libm::cos,
        counts: accurate_trig,
        outside: bounded,
    },
    Unary {
        name: "tan",
        ours: stateforge_math::f32::tan,
        reference: libm::tan,
        counts: accurate_trig,
        outside: finite,
    },
    Unary {
        name: "exp",
        ours: stateforge_math::f32::exp,
        reference: libm::exp,
        counts: all,
        outside: never,
    },
    Unary {
        name: "ln",
        ours: stateforge_math::f32::ln,
        reference: libm::log,
        counts: all,
        outside: never,
    },
    Unary {
        name: "tanh",
        ours: stateforge_math::f32::tanh,
        reference: libm::tanh,
        counts: all,
        outside: never,
    },
    Unary {
        name: "sqrt",
        ours: stateforge_math::f32::sqrt,
        reference: libm::sqrt,
        counts: all,
        outside: never,
    },
];

/// The largest error of `f` over the bit patterns `from..to`, its argument, and how many
/// inputs outside the counted domain gave a value of the wrong kind (the first of them).
fn scan(f: &Unary, from: u64, to: u64) -> (f64, f32, u64, Option<f32>) {
    let (mut worst, mut at, mut wrong, mut first_wrong) = (0.0_f64, 0.0_f32, 0, None);
    for bits in from..to {
        let x = f32::from_bits(bits as u32);
        let y = (f.ours)(x);
        if (f.counts)(x) || !x.is_finite() {
            let e = ulp_error(y, (f.reference)(f64::from(x)));
            if e > worst {
                (worst, at) = (e, x);
            }
        } else if !(f.outside)(x, y) {
            wrong += 1;
            first_wrong.get_or_insert(x);
        }
    }
    (worst, at, wrong, first_wrong)
}

/// Every `f32` bit pattern through `f`, split over the machine's threads.
fn exhaustive(f: &Unary) -> String {
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()) as u64;
    let chunk = (1u64 << 32) / 256;
    let next = AtomicU32::new(0);
    let results: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut acc = (0.0_f64, 0.0_f32, 0_u64, None);
                    loop {
                        let i = u64::from(next.fetch_add(1, Ordering::Relaxed));
                        if i >= 256 {
                            break acc;
                        }
                        let r = scan(f, i * chunk, (i + 1) * chunk);
                        if r.0 > acc.0 {
                            (acc.0, acc.1) = (r.0, r.1);
                        }
                        acc.2 += r.2;
                        acc.3 = acc.3.or(r.3);
                    }
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("scan"))
            .collect()
    });
    let worst = results.iter().fold(
        (0.0, 0.0_f32),
        |w, r| if r.0 > w.0 { (r.0, r.1) } else { w },
    );
    let wrong: u64 = results.iter().map(|r| r.2).sum();
    let mut line = format!(
        "{:<6} largest error {:.3} ulp at x = {:e} ({:#010x})",
        f.name,
        worst.0,
        worst.1,
        worst.1.to_bits()
    );
    if wrong > 0 {
        let first = results.iter().find_map(|r| r.3).unwrap_or(f32::NAN);
        line.push_str(&format!(
            "; {wrong} inputs outside the domain gave a wrong kind of value (first {first:e})"
        ));
    }
    line
}

/// `atan2` over a grid of 4096 x 4096 magnitudes spread over the whole range, in all four
/// quadrants, plus 2^28 random bit-pattern pairs.
fn atan2_errors() -> String {
    let check = |y: f32, x: f32, worst: &mut (f64, f32, f32)| {
        let e = ulp_error(
            stateforge_math::f32::atan2(y, x),
            libm::atan2(f64::from(y), f64::from(x)),
        );
        if e > worst.0 {
            *worst = (e, y, x);
        }
    };
    let threads = std::thread::available_parallelism().map_or(2, |n| n.get()) as u64;
    let grid: Vec<f32> = (0..4096u32)
        .map(|i| f32::from_bits(i << 19 | i & 0x7FFFF))
        .collect();
    let worst = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads)
            .map(|t| {
                let grid = &grid;
                scope.spawn(move || {
                    let mut worst = (0.0, 0.0, 0.0);
                    for (i, &a) in grid.iter().enumerate() {
                        if i as u64 % threads != t {
                            continue;
                        }
                        for &b in grid {
                            for (y, x) in [(a, b), (-a, b), (a, -b), (-a, -b)] {
                                check(y, x, &mut worst);
                            }
                        }
                    }
                    let mut random = Random(0x9E37_79B9_7F4A_7C15 ^ (t + 1));
                    for _ in 0..(1u64 << 28) / threads {
                        let bits = random.next();
                        check(
                            f32::from_bits(bits as u32),
                            f32::from_bits((bits >> 32) as u32),
                            &mut worst,
                        );
                    }
                    worst
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("atan2"))
            .fold((0.0, 0.0, 0.0), |w, r| if r.0 > w.0 { r } else { w })
    });
    format!(
        "atan2  largest error {:.3} ulp at (y, x) = ({:e}, {:e}) (grid 4096^2 x 4 quadrants, 2^28 random pairs)",
        worst.0, worst.1, worst.2
    )
}

/// The report, one line per function; `only` limits it to the functions named.
pub fn report(only: &[String]) -> String {
    let wanted = |name: &str| only.is_empty() || only.iter().any(|o| o == name);
    let mut out = String::from(
        "stateforge_math::f32 against libm f64, every f32 input (sin, cos, tan counted for \
         |x| <= TRIG_ACCURATE, finite and bounded checked beyond):\n",
    );
    for f in UNARY.iter().filter(|f| wanted(f.name)) {
        out.push_str(&exhaustive(f));
        out.push('\n');
    }
    if wanted("atan2") {
        out.push_str(&atan2_errors());
        out.push('\n');
    }
    out
}
