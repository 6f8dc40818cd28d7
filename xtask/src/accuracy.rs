//! How far the generated filters in `f32` drift from the same code in `f64`, over many
//! noise sequences: the host's `f32` arithmetic is the target's bit for bit (no library
//! call, no contraction), so the check `cargo xtask test` makes on one sequence can be
//! repeated on others here, in a second.

use crate::compare::{FLOORS, RTOL};
use generated_demo::cantilever::{self as single, in_f64 as double};
use generated_demo::sequence::Measured;

/// Samples per sequence, as the firmware's.
const SAMPLES: usize = 1000;
/// The firmware's guesses and tuning (targets/src/main.rs).
const CLOSE: ([f64; 5], [f64; 5]) = (
    [0.01, 0.0, -400.0, -1.0, 0.01],
    [0.1, 1.0, 2e4, 1000.0, 0.1],
);
const WRONG: ([f64; 5], [f64; 5]) = (
    [0.01, 0.0, -50000.0, -10.0, 0.01],
    [0.1, 1.0, 2e6, 1000.0, 0.1],
);
const Q: [f64; 5] = [0.0, 0.0, 100.0, 300.0, 1e-3];
const R: f64 = 0.001;

/// Per filter, over `sequences` noise sequences (the first is the CI's), the largest
/// relative difference of every tenth estimate (the CI check's measure): median, largest,
/// and how many sequences exceed the CI's tolerance.
pub fn report(sequences: u64) -> String {
    let seeds: Vec<u64> = std::iter::once(0x2545_F491_4F6C_DD1D)
        .chain((1..sequences).map(|i| i.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1))
        .collect();
    let mut out = format!(
        "Largest relative difference of every tenth f32 estimate from the f64 run, per \
         sequence, over {} noise sequences (the first is the CI's):\n",
        seeds.len()
    );
    for (name, filter) in [
        ("EKF", Filter::Ekf),
        ("DKF", Filter::Dkf(CLOSE)),
        ("DKF from the wrong guess", Filter::Dkf(WRONG)),
    ] {
        let mut worst: Vec<f64> = seeds
            .iter()
            .map(|&s| largest_difference(filter, s))
            .collect();
        let ci = worst[0];
        worst.sort_by(f64::total_cmp);
        let over = worst.iter().filter(|&&w| w > RTOL).count();
        out.push_str(&format!(
            "  {name:<25} CI sequence {ci:.1e}, median {:.1e}, largest {:.1e}, above {RTOL:e} on {over}\n",
            worst[worst.len() / 2],
            worst[worst.len() - 1],
        ));
    }
    out
}

#[derive(Clone, Copy)]
enum Filter {
    Ekf,
    Dkf(([f64; 5], [f64; 5])),
}

/// The largest relative difference of every tenth estimate on the sequence of `seed`.
fn largest_difference(filter: Filter, seed: u64) -> f64 {
    let data: Vec<(f32, f32)> = Measured::with_noise_seed(seed)
        .take(SAMPLES)
        .map(|s| (s.u, s.y))
        .collect();
    let narrow = |v: [f64; 5]| v.map(|x| x as f32);
    let diag = |d: [f64; 5]| {
        let mut m = [[0.0; 5]; 5];
        for (i, row) in m.iter_mut().enumerate() {
            row[i] = d[i];
        }
        m
    };
    let diag32 = |d: [f64; 5]| diag(d).map(narrow);
    let mut worst = 0.0f64;
    let mut compare = |single: [f32; 5], double: [f64; 5]| {
        for i in 0..5 {
            let error = (f64::from(single[i]) - double[i]).abs() / double[i].abs().max(FLOORS[i]);
            worst = worst.max(if error.is_nan() { f64::INFINITY } else { error });
        }
    };
    match filter {
        Filter::Ekf => {
            let (x0, p0) = CLOSE;
            let mut a = single::Ekf::new(&narrow(x0), &diag32(p0), &narrow(Q), &[[R as f32]])
                .expect("the tuning is finite");
            let mut b = double::Ekf::new(&x0, &diag(p0), &Q, &[[R]]).expect("the tuning is finite");
            for k in 1..data.len() {
                let (u, y) = (data[k - 1].0, data[k].1);
                let _ = a.step(&[u], &[y]);
                let _ = b.step(&[f64::from(u)], &[f64::from(y)]);
                if k % 10 == 0 {
                    compare(a.state(), b.state());
                }
            }
        }
        Filter::Dkf((x0, p0)) => {
            let (p32, q32) = (diag32(p0), narrow(Q));
            let mut a = single::Dkf::new(&narrow(x0), &p32, &q32, &p32, &q32, &[[R as f32]])
                .expect("the tuning is finite");
            let mut b = double::Dkf::new(&x0, &diag(p0), &Q, &diag(p0), &Q, &[[R]])
                .expect("the tuning is finite");
            for k in 1..data.len() {
                let (u, y) = (data[k - 1].0, data[k].1);
                let _ = a.step(&[u], &[y]);
                let _ = b.step(&[f64::from(u)], &[f64::from(y)]);
                if k % 10 == 0 {
                    compare(a.state(), b.state());
                }
            }
        }
    }
    worst
}
