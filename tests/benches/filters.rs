//! Host benchmarks of the cantilever's generated filters against the straightforward
//! nalgebra reference (`tests/src/reference.rs`), in one run:
//! `cargo bench -p tests --bench filters`. Each step runs on recorded data in a loop so
//! the filters stay in their steady state.

use criterion::{criterion_group, criterion_main, Criterion};
use generated_demo::cantilever;
use generated_demo::cantilever::in_f64::{Dkf, Ekf, Lqr};
use nalgebra::{Matrix2, SMatrix};
use std::hint::black_box;
use tests::cantilever_sim::{run, Sample};
use tests::reference::{self, State};
use tests::tuning::{diag, Q_DIAG, R, X0_CLOSE as X0};

fn mat(m: &[[f64; 5]; 5]) -> SMatrix<f64, 5, 5> {
    SMatrix::from_fn(|i, j| m[i][j])
}

/// Cycles through the recorded samples: `(u[k-1], y[k])`.
struct Feed {
    samples: Vec<Sample>,
    k: usize,
}

impl Feed {
    fn new() -> Feed {
        Feed {
            samples: run(2000, 1e-4, 9),
            k: 0,
        }
    }

    fn next(&mut self) -> (f64, f64) {
        self.k = self.k % (self.samples.len() - 1) + 1;
        (self.samples[self.k - 1].u, self.samples[self.k].y)
    }
}

/// One EKF step: the generated `f64` and `f32` filters and the nalgebra reference.
fn bench_ekf_step(c: &mut Criterion, p0: &[[f64; 5]; 5], q: &[[f64; 5]; 5]) {
    let mut group = c.benchmark_group("EKF step");
    let (mut ekf, mut feed) = (Ekf::new(&X0, p0, &Q_DIAG, &[[R]]).unwrap(), Feed::new());
    group.bench_function("generated f64", |b| {
        b.iter(|| {
            let (u, y) = feed.next();
            black_box(ekf.step(&[black_box(u)], &[black_box(y)]))
        })
    });
    let mut ekf32 = cantilever::Ekf::new(
        &X0.map(|v| v as f32),
        &p0.map(|r| r.map(|v| v as f32)),
        &Q_DIAG.map(|v| v as f32),
        &[[R as f32]],
    )
    .unwrap();
    let mut feed = Feed::new();
    group.bench_function("generated f32", |b| {
        b.iter(|| {
            let (u, y) = feed.next();
            black_box(ekf32.step(&[black_box(u as f32)], &[black_box(y as f32)]))
        })
    });
    let mut reference = reference::Ekf::new(State::from(X0), mat(p0), mat(q), SMatrix::from([[R]]));
    let mut feed = Feed::new();
    group.bench_function("nalgebra reference", |b| {
        b.iter(|| {
            let (u, y) = feed.next();
            black_box(reference.step(black_box(u), black_box(y)))
        })
    });
    group.finish();
}

/// One DKF step: the generated `f64` filter and the nalgebra reference.
fn bench_dkf_step(c: &mut Criterion, p0: &[[f64; 5]; 5], q: &[[f64; 5]; 5]) {
    let mut group = c.benchmark_group("DKF step");
    let (mut dkf, mut feed) = (
        Dkf::new(&X0, p0, &Q_DIAG, p0, &Q_DIAG, &[[R]]).unwrap(),
        Feed::new(),
    );
    group.bench_function("generated f64", |b| {
        b.iter(|| {
            let (u, y) = feed.next();
            black_box(dkf.step(&[black_box(u)], &[black_box(y)]))
        })
    });
    let mut reference = reference::Dkf::new(
        State::from(X0),
        mat(p0),
        mat(q),
        mat(q),
        SMatrix::from([[R]]),
        0.5,
    );
    let mut feed = Feed::new();
    group.bench_function("nalgebra reference", |b| {
        b.iter(|| {
            let (u, y) = feed.next();
            black_box(reference.step(black_box(u), black_box(y)))
        })
    });
    group.finish();
}

/// One LQR solve over a horizon of 50: the generated `f64` solver and the nalgebra
/// reference.
fn bench_lqr_solve(c: &mut Criterion) {
    let mut group = c.benchmark_group("LQR solve (N = 50)");
    let estimate = [0.1, 0.2, -393.93, -6.941, 0.4924];
    let mut lqr = Lqr::new(&[[1.0, 0.0], [0.0, 1.0]], &[[0.001]], Some(&[100.0])).unwrap();
    group.bench_function("generated f64", |b| {
        b.iter(|| black_box(lqr.solve(black_box(&estimate), black_box(&[0.0]))))
    });
    group.bench_function("nalgebra reference", |b| {
        b.iter(|| {
            black_box(reference::lqr_gain(
                black_box(&estimate),
                50,
                Matrix2::identity(),
                0.001,
            ))
        })
    });
    group.finish();
}

/// Every benchmark group, on the cantilever's tuning.
fn benches(c: &mut Criterion) {
    let p0 = diag([0.1, 1.0, 2e4, 1000.0, 0.1]);
    let q = diag(Q_DIAG);
    bench_ekf_step(c, &p0, &q);
    bench_dkf_step(c, &p0, &q);
    bench_lqr_solve(c);
}

criterion_group! {
    name = filters;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = benches
}
criterion_main!(filters);
