//! Eigenvalues of a small real matrix: Householder reduction to Hessenberg form, then the
//! shifted QR algorithm in complex arithmetic (Givens rotations, Wilkinson shifts,
//! deflation), which is simple and robust for the sizes designs have (n <= 20 or so).
//! The eigenvalues are the stability certificate: a discrete-time system is Schur stable
//! when every pole lies inside the unit circle, a continuous-time one Hurwitz stable when
//! every pole has a negative real part.

use super::matrix::Mat;

/// A complex number, for eigenvalues.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Complex {
    /// Real part.
    pub re: f64,
    /// Imaginary part.
    pub im: f64,
}

impl Complex {
    const ZERO: Complex = Complex { re: 0.0, im: 0.0 };

    fn new(re: f64, im: f64) -> Complex {
        Complex { re, im }
    }

    /// The modulus.
    pub fn abs(self) -> f64 {
        self.re.hypot(self.im)
    }

    fn conj(self) -> Complex {
        Complex::new(self.re, -self.im)
    }

    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }

    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }

    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    fn scale(self, s: f64) -> Complex {
        Complex::new(self.re * s, self.im * s)
    }

    fn sqrt(self) -> Complex {
        let r = self.abs();
        let re = ((r + self.re) / 2.0).max(0.0).sqrt();
        let im = ((r - self.re) / 2.0).max(0.0).sqrt();
        Complex::new(re, if self.im < 0.0 { -im } else { im })
    }
}

impl std::fmt::Display for Complex {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.im == 0.0 {
            write!(f, "{:.6}", self.re)
        } else {
            let sign = if self.im < 0.0 { '-' } else { '+' };
            write!(f, "{:.6} {sign} {:.6}i", self.re, self.im.abs())
        }
    }
}

/// The eigenvalues of the square matrix `a`, in no particular order, or `None` if the QR
/// iteration does not converge (or `a` is not finite).
pub fn eigenvalues(a: &Mat) -> Option<Vec<Complex>> {
    let n = a.rows();
    if n != a.cols() || !a.is_finite() {
        return None;
    }
    let hess = hessenberg(a);
    let mut h: Vec<Vec<Complex>> = (0..n)
        .map(|i| (0..n).map(|j| Complex::new(hess[(i, j)], 0.0)).collect())
        .collect();
    let mut values = Vec::with_capacity(n);
    let mut hi = n;
    let mut iterations = 0;
    while hi > 0 {
        let top = hi - 1;
        // Deflate at the lowest negligible subdiagonal entry above the active block's end.
        let mut lo = top;
        while lo > 0 {
            let scale = h[lo][lo].abs() + h[lo - 1][lo - 1].abs();
            if h[lo][lo - 1].abs() <= f64::EPSILON * scale.max(f64::MIN_POSITIVE) {
                h[lo][lo - 1] = Complex::ZERO;
                break;
            }
            lo -= 1;
        }
        if lo == top {
            values.push(h[top][top]);
            hi -= 1;
            iterations = 0;
            continue;
        }
        iterations += 1;
        if iterations > 200 {
            return None;
        }
        let shift = if iterations % 11 == 10 {
            // An exceptional shift breaks the rare cycles of the Wilkinson shift.
            h[top][top].add(Complex::new(
                h[top][top - 1].abs() * 0.75,
                h[top][top - 1].abs() * 0.5,
            ))
        } else {
            wilkinson_shift(
                h[top - 1][top - 1],
                h[top - 1][top],
                h[top][top - 1],
                h[top][top],
            )
        };
        qr_step(&mut h, lo, top, shift);
    }
    Some(values)
}

/// The eigenvalue of the trailing 2 x 2 block closest to its last diagonal entry.
fn wilkinson_shift(a: Complex, b: Complex, c: Complex, d: Complex) -> Complex {
    let half_trace = a.add(d).scale(0.5);
    let det = a.mul(d).sub(b.mul(c));
    let disc = half_trace.mul(half_trace).sub(det).sqrt();
    let (l1, l2) = (half_trace.add(disc), half_trace.sub(disc));
    if l1.sub(d).abs() < l2.sub(d).abs() {
        l1
    } else {
        l2
    }
}

/// One shifted QR step on the block `lo..=hi` of the Hessenberg matrix `h`:
/// `H - mu I = Q R`, `H <- R Q + mu I`, with Givens rotations.
#[allow(clippy::needless_range_loop)] // rotations pair rows k, k + 1: indices read best
fn qr_step(h: &mut [Vec<Complex>], lo: usize, hi: usize, mu: Complex) {
    for k in lo..=hi {
        h[k][k] = h[k][k].sub(mu);
    }
    let mut rotations = Vec::with_capacity(hi - lo);
    for k in lo..hi {
        let (a, b) = (h[k][k], h[k + 1][k]);
        let norm = (a.abs().powi(2) + b.abs().powi(2)).sqrt();
        let (c, s) = if norm == 0.0 {
            (1.0, Complex::ZERO)
        } else if a.abs() == 0.0 {
            (0.0, Complex::new(1.0, 0.0))
        } else {
            let phase = a.scale(1.0 / a.abs());
            (a.abs() / norm, phase.mul(b.conj()).scale(1.0 / norm))
        };
        for j in k..=hi {
            let (x, y) = (h[k][j], h[k + 1][j]);
            h[k][j] = x.scale(c).add(s.mul(y));
            h[k + 1][j] = y.scale(c).sub(s.conj().mul(x));
        }
        rotations.push((c, s));
    }
    for (k, (c, s)) in (lo..hi).zip(rotations) {
        for row in h.iter_mut().take((k + 2).min(hi) + 1).skip(lo) {
            let (x, y) = (row[k], row[k + 1]);
            row[k] = x.scale(c).add(y.mul(s.conj()));
            row[k + 1] = y.scale(c).sub(x.mul(s));
        }
    }
    for k in lo..=hi {
        h[k][k] = h[k][k].add(mu);
    }
}

/// An orthogonally similar upper Hessenberg matrix (Householder reflections).
fn hessenberg(a: &Mat) -> Mat {
    let n = a.rows();
    let mut h = a.clone();
    for k in 0..n.saturating_sub(2) {
        let norm = (k + 1..n).map(|i| h[(i, k)].powi(2)).sum::<f64>().sqrt();
        if norm == 0.0 {
            continue;
        }
        let alpha = if h[(k + 1, k)] > 0.0 { -norm } else { norm };
        let mut v: Vec<f64> = (0..n)
            .map(|i| if i > k { h[(i, k)] } else { 0.0 })
            .collect();
        v[k + 1] -= alpha;
        let vv: f64 = v.iter().map(|x| x * x).sum();
        if vv == 0.0 {
            continue;
        }
        // H <- (I - 2 v v' / v'v) H (I - 2 v v' / v'v)
        for j in 0..n {
            let dot: f64 = (k + 1..n).map(|i| v[i] * h[(i, j)]).sum();
            for i in k + 1..n {
                h[(i, j)] -= 2.0 * v[i] * dot / vv;
            }
        }
        for i in 0..n {
            let dot: f64 = (k + 1..n).map(|j| h[(i, j)] * v[j]).sum();
            for j in k + 1..n {
                h[(i, j)] -= 2.0 * dot * v[j] / vv;
            }
        }
    }
    h
}

/// The pole of largest modulus of a discrete-time system matrix, or `None` if its
/// eigenvalues could not be computed. The system is Schur stable when its modulus is < 1.
pub fn largest_pole(a: &Mat) -> Option<Complex> {
    eigenvalues(a)?
        .into_iter()
        .max_by(|p, q| p.abs().total_cmp(&q.abs()))
}

/// The pole of largest real part of a continuous-time system matrix, or `None` if its
/// eigenvalues could not be computed. The system is Hurwitz stable when it is < 0.
pub fn rightmost_pole(a: &Mat) -> Option<Complex> {
    eigenvalues(a)?
        .into_iter()
        .max_by(|p, q| p.re.total_cmp(&q.re))
}
