//! Host benchmark of the blade's generated MPC against the same box-constrained QP solved
//! by Clarabel, in one run: `cargo bench -p tests --bench mpc`. The problem is the blade
//! just after an impact (q = 4 mm, q' = 0.2 m/s, 1/m = 5 1/kg) under the paper's weights
//! (`Q = C'C`, `R = 1e-10`) and +-100 V, where several moves sit on their bounds.
//!
//! Timed pieces:
//! - `generated f64 solve`: one whole `Mpc::solve` from the same controller state (the
//!   terminal weight converged at this estimate, the plan warm-started from the last
//!   solve's): the zero-order hold at the estimate, the Riccati steps, the condensed
//!   problem and the active-set iterations;
//! - `Clarabel (H, c given)`: `predictive_reference::box_qp` on the condensed `H`, `c`
//!   built beforehand: Clarabel's setup and interior-point solve, then the reference's
//!   polish on the active set (a Cholesky solve on the free moves and an optimality check);
//! - `condensing + Clarabel`: the same with `H`, `c` built by
//!   `predictive_reference::condensed` from `A`, `B` and the terminal weight (nalgebra,
//!   heap-allocated) inside the timed call.

use criterion::{criterion_group, criterion_main, Criterion};
use generated_demo::mass_spring_damper::in_f64::Mpc;
use generated_demo::mass_spring_damper::Status;
use nalgebra::{DMatrix, DVector};
use std::hint::black_box;
use tests::predictive_reference::{box_qp, condensed};

const Q: [[f64; 2]; 2] = [[1.0, 0.0], [0.0, 0.0]];
const R: [[f64; 1]; 1] = [[1e-10]];
const LIMIT: f64 = 100.0;
const X: [f64; 5] = [0.004, 0.2, 0.0, 0.0, 5.0];

fn matrix<const R: usize, const C: usize>(m: &[[f64; C]; R]) -> DMatrix<f64> {
    DMatrix::from_fn(R, C, |i, j| m[i][j])
}

fn benches(c: &mut Criterion) {
    let mut mpc = Mpc::new(&Q, &R, &[-LIMIT], &[LIMIT]).expect("valid bounds");
    let mut converged = false;
    for _ in 0..200 {
        let status = mpc.solve(&X, &[0.0]);
        assert_eq!(status.status, Status::Ok);
        if status.terminal_weight_converged && status.optimal {
            converged = true;
            break;
        }
    }
    assert!(converged, "the terminal weight did not converge");
    let model = Mpc::prediction_model(&X, &[0.0]).expect("finite");
    let (a, b) = (matrix(&model.a), matrix(&model.b));
    let (q, r, p) = (matrix(&Q), matrix(&R), matrix(&mpc.terminal_weight()));
    let x0 = DVector::from_vec(vec![X[0], X[1]]);
    let (h, lin) = condensed((&a, &b), (&q, &r, &p), &x0, Mpc::HORIZON);
    let (low, high) = ([-LIMIT; Mpc::HORIZON], [LIMIT; Mpc::HORIZON]);

    // The same problem: the generated plan is Clarabel's, with several bounds held.
    let expected = box_qp(&h, &lin, &low, &high);
    let mut check = mpc;
    let status = check.solve(&X, &[0.0]);
    assert!(status.optimal, "{status:?}");
    let mut held = 0;
    for (u, v) in check.plan().iter().zip(expected.iter()) {
        assert!(
            (u[0] - v).abs() < 1e-6,
            "generated {} vs Clarabel {v}",
            u[0]
        );
        held += usize::from((v.abs() - LIMIT).abs() < 1e-6);
    }
    assert!(held >= 2, "only {held} moves on a bound");
    println!(
        "the timed solve: {} active-set iterations, {held} of {} moves on a bound",
        status.iterations,
        Mpc::HORIZON
    );

    let mut group = c.benchmark_group("MPC solve (blade, n = 10)");
    group.bench_function("generated f64 solve", |bencher| {
        bencher.iter(|| {
            let mut controller = mpc;
            black_box(controller.solve(black_box(&X), &[0.0]))
        })
    });
    group.bench_function("Clarabel (H, c given)", |bencher| {
        bencher.iter(|| black_box(box_qp(black_box(&h), black_box(&lin), &low, &high)))
    });
    group.bench_function("condensing + Clarabel", |bencher| {
        bencher.iter(|| {
            let (h, lin) = condensed((&a, &b), (&q, &r, &p), black_box(&x0), Mpc::HORIZON);
            black_box(box_qp(&h, &lin, &low, &high))
        })
    });
    group.finish();
}

criterion_group!(mpc_benches, benches);
criterion_main!(mpc_benches);
