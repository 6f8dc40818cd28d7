//! The build-time numerics of `stateforge_compiler::numerics` against nalgebra: the
//! pseudo-inverse and rank against nalgebra's SVD, eigenvalues against its Schur form, and
//! the Riccati solutions by their residual computed here with nalgebra (and the closed
//! loop's poles).

use nalgebra::DMatrix;
use stateforge_compiler::numerics::{self, Mat};
use tests::rng::Lcg;

/// A random `rows x cols` matrix with entries in [-1, 1).
fn random_mat(rng: &mut Lcg, rows: usize, cols: usize) -> Mat {
    Mat::from_rows(
        &(0..rows)
            .map(|_| (0..cols).map(|_| rng.uniform()).collect())
            .collect::<Vec<_>>(),
    )
}

fn to_na(m: &Mat) -> DMatrix<f64> {
    DMatrix::from_fn(m.rows(), m.cols(), |i, j| m[(i, j)])
}

fn max_diff(a: &Mat, b: &DMatrix<f64>) -> f64 {
    (to_na(a) - b).abs().max()
}

#[test]
fn pseudo_inverse_matches_nalgebra_svd() {
    let mut rng = Lcg(7);
    for (rows, cols) in [(7, 4), (4, 7), (6, 6), (12, 4), (1, 5)] {
        for _ in 0..20 {
            let a = random_mat(&mut rng, rows, cols);
            let ours = numerics::pinv(&a);
            let theirs = to_na(&a).pseudo_inverse(1e-12).unwrap();
            let diff = max_diff(&ours, &theirs);
            assert!(diff < 1e-11 * theirs.abs().max(), "{rows}x{cols}: {diff:e}");
        }
    }
    // Rank-deficient: a 6 x 5 matrix of rank 3.
    for _ in 0..20 {
        let a = &random_mat(&mut rng, 6, 3) * &random_mat(&mut rng, 3, 5);
        let ours = numerics::pinv(&a);
        let na = to_na(&a);
        let svd = na.clone().svd(true, true);
        let tol = 6.0 * f64::EPSILON * svd.singular_values.max();
        let theirs = svd.pseudo_inverse(tol).unwrap();
        let diff = max_diff(&ours, &theirs);
        assert!(diff < 1e-9 * theirs.abs().max(), "rank 3: {diff:e}");
        assert_eq!(numerics::rank(&a), na.rank(tol));
        assert_eq!(numerics::rank(&a), 3);
    }
}

/// The polynomial fit of the polynomial Kalman filter: a tall Vandermonde matrix.
#[test]
fn pseudo_inverse_of_a_polynomial_fit_matches_nalgebra() {
    for (window, order) in [(10usize, 2usize), (20, 3), (50, 3), (100, 4)] {
        let h = Mat::from_rows(
            &(0..window)
                .map(|i| {
                    let t = i as f64 - (window - 1) as f64;
                    (0..=order).map(|j| t.powi(j as i32)).collect()
                })
                .collect::<Vec<_>>(),
        );
        let ours = numerics::pinv(&h);
        let svd = to_na(&h).svd(true, true);
        // Two backward-stable pseudo-inverses differ by up to about eps times the
        // condition number (1e8 for a window of 100 and order 4), relative.
        let condition = svd.singular_values.max() / svd.singular_values.min();
        let theirs = svd.pseudo_inverse(1e-300).unwrap();
        let diff = max_diff(&ours, &theirs);
        let bound = 100.0 * f64::EPSILON * condition * theirs.abs().max();
        assert!(
            diff < bound,
            "{window}, {order}: {diff:e} (bound {bound:e})"
        );
        // With time scaled to the window (as the generator fits), the matrix is well
        // conditioned and the Penrose condition pinv(H) H = I holds to 1e-12.
        let span = (window - 1) as f64;
        let scaled = Mat::from_rows(
            &h.to_rows()
                .iter()
                .map(|row| {
                    row.iter()
                        .enumerate()
                        .map(|(j, v)| v / span.powi(j as i32))
                        .collect()
                })
                .collect::<Vec<_>>(),
        );
        let identity = to_na(&(&numerics::pinv(&scaled) * &scaled));
        let off = (identity - DMatrix::<f64>::identity(order + 1, order + 1))
            .abs()
            .max();
        assert!(off < 1e-12, "{window}, {order}: pinv(H) H - I = {off:e}");
    }
}

#[test]
fn eigenvalues_match_nalgebra() {
    let mut rng = Lcg(11);
    for n in [1, 2, 3, 5, 6, 8, 12] {
        for _ in 0..20 {
            let a = random_mat(&mut rng, n, n);
            let ours = numerics::eigenvalues(&a).expect("converges");
            let mut theirs: Vec<(f64, f64)> = to_na(&a)
                .complex_eigenvalues()
                .iter()
                .map(|c| (c.re, c.im))
                .collect();
            assert_eq!(ours.len(), n);
            // Pair each of ours with the nearest of theirs not yet paired.
            for o in &ours {
                let (i, d) = theirs
                    .iter()
                    .map(|t| (o.re - t.0).hypot(o.im - t.1))
                    .enumerate()
                    .min_by(|x, y| x.1.total_cmp(&y.1))
                    .unwrap();
                assert!(d < 1e-9, "n = {n}: {o} is {d:e} from the nearest");
                theirs.remove(i);
            }
        }
    }
}

#[test]
fn the_stability_certificate_names_the_worst_pole() {
    // A rotation slightly outside the unit circle, and a Hurwitz matrix.
    let a = Mat::from_rows(&[vec![0.0, -1.003], vec![1.003, 0.0]]);
    let pole = numerics::largest_pole(&a).unwrap();
    assert!((pole.abs() - 1.003).abs() < 1e-12);
    let b = Mat::from_rows(&[vec![-0.4, 10.0], vec![-10.0, -1.0]]);
    let right = numerics::rightmost_pole(&b).unwrap();
    assert!((right.re + 0.7).abs() < 1e-12, "{right}");
}

/// Residual of the DARE computed independently with nalgebra, relative to |X| + |Q|.
fn na_dare_residual(a: &Mat, b: &Mat, q: &Mat, r: &Mat, x: &Mat) -> f64 {
    let (a, b, q, r, x) = (to_na(a), to_na(b), to_na(q), to_na(r), to_na(x));
    let s = &r + b.transpose() * &x * &b;
    let k = s.try_inverse().unwrap() * b.transpose() * &x * &a;
    let rhs = a.transpose() * &x * &a - a.transpose() * &x * &b * k + &q;
    (&x - rhs).norm() / (x.norm() + q.norm())
}

fn spd(rng: &mut Lcg, n: usize, floor: f64) -> Mat {
    let m = random_mat(rng, n, n);
    &(&m * &m.t()) + &Mat::identity(n).scale(floor)
}

#[test]
fn dare_residual_is_below_1e_10_and_the_loop_is_stable() {
    let mut rng = Lcg(3);
    for (n, m) in [(2, 1), (4, 2), (6, 2), (6, 1)] {
        for trial in 0..20 {
            // Unstable open loops as well as stable ones.
            let a = random_mat(&mut rng, n, n).scale(if trial % 2 == 0 { 1.4 } else { 0.5 });
            let b = random_mat(&mut rng, n, m);
            let q = spd(&mut rng, n, 0.1);
            let r = spd(&mut rng, m, 0.5);
            let x = numerics::dare(&a, &b, &q, &r).expect("solvable");
            let residual = na_dare_residual(&a, &b, &q, &r, &x);
            assert!(residual < 1e-10, "{n}x{m} #{trial}: residual {residual:e}");
            let (an, bn, rn, xn) = (to_na(&a), to_na(&b), to_na(&r), to_na(&x));
            let k = (&rn + bn.transpose() * &xn * &bn).try_inverse().unwrap()
                * bn.transpose()
                * &xn
                * &an;
            let radius = (an - bn * k)
                .complex_eigenvalues()
                .iter()
                .map(|c| c.norm())
                .fold(0.0, f64::max);
            assert!(radius < 1.0, "closed loop radius {radius}");
        }
    }
}

#[test]
fn kalman_predictor_gain_is_the_limit_of_the_riccati_recursion() {
    // A lightly damped oscillator sampled fast (poles near 1), as the beam's regimes.
    let (w, z, ts) = (2.0 * std::f64::consts::PI * 20.0, 0.01, 0.0005);
    let a = Mat::from_rows(&[
        vec![1.0 - ts * ts * w * w, ts - ts * ts * 2.0 * z * w],
        vec![-ts * w * w, 1.0 - ts * 2.0 * z * w],
    ]);
    let c = Mat::from_rows(&[vec![1.0, 0.0]]);
    let q = Mat::diagonal(&[1e-10, 1e-6]);
    let r = Mat::diagonal(&[1e-9]);
    let (k, p) = numerics::kalman_predictor_gain(&a, &c, &q, &r).unwrap();
    let (an, cn, qn, rn) = (to_na(&a), to_na(&c), to_na(&q), to_na(&r));
    let mut pn = DMatrix::<f64>::identity(2, 2) * 1e-6;
    for _ in 0..200_000 {
        let s = &cn * &pn * cn.transpose() + &rn;
        let gain = &an * &pn * cn.transpose() * s.try_inverse().unwrap();
        pn = &an * &pn * an.transpose() + &qn - &gain * &cn * &pn * an.transpose();
    }
    let s = &cn * &pn * cn.transpose() + &rn;
    let kn = &an * &pn * cn.transpose() * s.try_inverse().unwrap();
    assert!((to_na(&k) - &kn).abs().max() < 1e-8 * kn.abs().max());
    assert!((to_na(&p) - &pn).abs().max() < 1e-8 * pn.abs().max());
    let residual = na_dare_residual(&a.t(), &c.t(), &q, &r, &p);
    assert!(residual < 1e-10, "{residual:e}");
}

#[test]
fn care_residual_is_below_1e_10_and_the_loop_is_hurwitz() {
    let mut rng = Lcg(5);
    for (n, m) in [(2, 1), (4, 2), (6, 2)] {
        for trial in 0..20 {
            let a = random_mat(&mut rng, n, n).scale(if trial % 2 == 0 { 2.0 } else { 0.5 });
            let b = random_mat(&mut rng, n, m);
            let q = spd(&mut rng, n, 0.1);
            let r = spd(&mut rng, m, 0.5);
            let x = numerics::care(&a, &b, &q, &r).expect("solvable");
            let (an, bn, qn, rn, xn) = (to_na(&a), to_na(&b), to_na(&q), to_na(&r), to_na(&x));
            let rinv = rn.try_inverse().unwrap();
            let lhs =
                an.transpose() * &xn + &xn * &an - &xn * &bn * &rinv * bn.transpose() * &xn + &qn;
            let residual = lhs.norm() / ((an.transpose() * &xn).norm() + qn.norm());
            assert!(residual < 1e-10, "{n}x{m} #{trial}: residual {residual:e}");
            let rightmost = (&an - &bn * &rinv * bn.transpose() * &xn)
                .complex_eigenvalues()
                .iter()
                .map(|c| c.re)
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(rightmost < 0.0, "closed loop pole at {rightmost}");
        }
    }
}

#[test]
fn observability_rank_sees_an_unmeasured_decoupled_mode() {
    let mut rng = Lcg(9);
    let a = random_mat(&mut rng, 4, 4);
    let c = random_mat(&mut rng, 1, 4);
    assert_eq!(numerics::observability_rank(&a, &c), 4);
    // Block diagonal with the second block unmeasured: rank 2.
    let mut blocked = Mat::zeros(4, 4);
    for i in 0..2 {
        for j in 0..2 {
            blocked[(i, j)] = a[(i, j)];
            blocked[(i + 2, j + 2)] = a[(i + 2, j + 2)];
        }
    }
    let c = Mat::from_rows(&[vec![1.0, 0.5, 0.0, 0.0]]);
    assert_eq!(numerics::observability_rank(&blocked, &c), 2);
    // A fast-sampled oscillator measured in position is observable.
    let ts = 0.0005;
    let osc = Mat::from_rows(&[vec![1.0, ts], vec![-ts * 1e4, 1.0 - ts]]);
    assert_eq!(
        numerics::observability_rank(&osc, &Mat::from_rows(&[vec![1.0, 0.0]])),
        2
    );
}
