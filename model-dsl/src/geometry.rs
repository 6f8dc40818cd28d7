//! Vectors and rotations over any algebra of scalars: written once, and used both where a
//! model's typed expressions are expanded into scalar ones (`check`) and where the
//! symbolic graph needs a rotation of its own nodes.
//!
//! Rotations are unit quaternions stored `[x, y, z, w]` (nalgebra's `Quaternion::coords`,
//! SymForce's `Rot3` storage), in Hamilton's convention: `q * v` rotates `v` actively, so
//! a body-to-earth attitude maps body vectors into the earth frame. Formulas are those of
//! J. Solà, "Quaternion kinematics for the error-state Kalman filter" (2017), cited by
//! equation number.

use crate::ast::Comparison;
use crate::model::Func;

/// The scalar operations the geometry is built of.
pub trait Algebra {
    /// A scalar value.
    type S: Clone;
    /// A literal.
    fn num(&mut self, value: f64) -> Self::S;
    /// `a + b`
    fn add(&mut self, a: Self::S, b: Self::S) -> Self::S;
    /// `a - b`
    fn sub(&mut self, a: Self::S, b: Self::S) -> Self::S;
    /// `a * b`
    fn mul(&mut self, a: Self::S, b: Self::S) -> Self::S;
    /// `a / b`
    fn div(&mut self, a: Self::S, b: Self::S) -> Self::S;
    /// `-a`
    fn neg(&mut self, a: Self::S) -> Self::S;
    /// A function of one argument.
    fn call(&mut self, f: Func, a: Self::S) -> Self::S;
    /// `atan2(y, x)`
    fn atan2(&mut self, y: Self::S, x: Self::S) -> Self::S;
    /// `if lhs cmp rhs { then } else { otherwise }`
    fn select(
        &mut self,
        cmp: Comparison,
        lhs: Self::S,
        rhs: Self::S,
        then: Self::S,
        otherwise: Self::S,
    ) -> Self::S;
    /// A value that is read more than once, computed once (a named intermediate where the
    /// algebra is a tree; itself where it shares common subexpressions already). `hint`
    /// names it in generated code.
    fn share(&mut self, a: Self::S, hint: &str) -> Self::S;
}

/// A 3-vector.
pub type Vec3<S> = [S; 3];

/// A unit quaternion `[x, y, z, w]`.
pub type Quat<S> = [S; 4];

/// The names of a vector's entries and of a rotation's stored entries, in the order of
/// [`Vec3`] and [`Quat`]; the model's types name their entries by them
/// ([`crate::model::Type::entries`]), where they are defined so that this file imports the
/// model and not the other way round.
pub use crate::model::{QUAT_ENTRIES, VEC3_ENTRIES};

/// `ε²` of the exponential map and the logarithm: `|θ|` is computed as `sqrt(θ·θ + ε²)`,
/// which keeps both total at `θ = 0` with no branch. One literal serves `f32` and `f64`:
/// it changes `cos(|θ|/2)` by at most `ε²/8` and `sin(|θ|/2)/|θ|` by `ε²/48` (both flat
/// at 0), below `f64`'s rounding of 1 (1.1e-16); and the fourth power the second
/// derivative divides by, `ε⁴ = 1e-36`, is above `f32`'s smallest normal number (1.2e-38).
pub const ANGLE_EPSILON_SQUARED: f64 = 1e-18;

/// Each entry shared.
pub fn share3<A: Algebra>(alg: &mut A, v: Vec3<A::S>, hint: &str) -> Vec3<A::S> {
    let [x, y, z] = v;
    [
        alg.share(x, &format!("{hint}_x")),
        alg.share(y, &format!("{hint}_y")),
        alg.share(z, &format!("{hint}_z")),
    ]
}

/// Each entry shared.
pub fn share4<A: Algebra>(alg: &mut A, q: Quat<A::S>, hint: &str) -> Quat<A::S> {
    let [x, y, z, w] = q;
    [
        alg.share(x, &format!("{hint}_x")),
        alg.share(y, &format!("{hint}_y")),
        alg.share(z, &format!("{hint}_z")),
        alg.share(w, &format!("{hint}_w")),
    ]
}

/// `a + b`, entry by entry.
pub fn add<A: Algebra>(alg: &mut A, a: Vec3<A::S>, b: Vec3<A::S>) -> Vec3<A::S> {
    let [ax, ay, az] = a;
    let [bx, by, bz] = b;
    [alg.add(ax, bx), alg.add(ay, by), alg.add(az, bz)]
}

/// `a - b`, entry by entry.
pub fn sub<A: Algebra>(alg: &mut A, a: Vec3<A::S>, b: Vec3<A::S>) -> Vec3<A::S> {
    let [ax, ay, az] = a;
    let [bx, by, bz] = b;
    [alg.sub(ax, bx), alg.sub(ay, by), alg.sub(az, bz)]
}

/// `-a`
pub fn neg<A: Algebra>(alg: &mut A, a: Vec3<A::S>) -> Vec3<A::S> {
    a.map(|e| alg.neg(e))
}

/// `s a`; `s` is read three times, so it is shared.
pub fn scale<A: Algebra>(alg: &mut A, s: A::S, a: Vec3<A::S>) -> Vec3<A::S> {
    let s = alg.share(s, "scale");
    a.map(|e| alg.mul(s.clone(), e))
}

/// `a / s`; `s` is read three times, so it is shared.
pub fn div_scalar<A: Algebra>(alg: &mut A, a: Vec3<A::S>, s: A::S) -> Vec3<A::S> {
    let s = alg.share(s, "divisor");
    a.map(|e| alg.div(e, s.clone()))
}

/// `a · b`
pub fn dot<A: Algebra>(alg: &mut A, a: Vec3<A::S>, b: Vec3<A::S>) -> A::S {
    let [ax, ay, az] = a;
    let [bx, by, bz] = b;
    let (xx, yy, zz) = (alg.mul(ax, bx), alg.mul(ay, by), alg.mul(az, bz));
    let xy = alg.add(xx, yy);
    alg.add(xy, zz)
}

/// `a × b`; each entry is read twice, so both are shared.
pub fn cross<A: Algebra>(alg: &mut A, a: Vec3<A::S>, b: Vec3<A::S>) -> Vec3<A::S> {
    let [ax, ay, az] = share3(alg, a, "lhs");
    let [bx, by, bz] = share3(alg, b, "rhs");
    let mut term = |p: &A::S, q: &A::S, r: &A::S, s: &A::S| {
        let pq = alg.mul(p.clone(), q.clone());
        let rs = alg.mul(r.clone(), s.clone());
        alg.sub(pq, rs)
    };
    [
        term(&ay, &bz, &az, &by),
        term(&az, &bx, &ax, &bz),
        term(&ax, &by, &ay, &bx),
    ]
}

/// `|a|²`
pub fn norm_squared<A: Algebra>(alg: &mut A, a: Vec3<A::S>) -> A::S {
    let a = share3(alg, a, "v");
    dot(alg, a.clone(), a)
}

/// `|a|`
pub fn norm<A: Algebra>(alg: &mut A, a: Vec3<A::S>) -> A::S {
    let squared = norm_squared(alg, a);
    alg.call(Func::Sqrt, squared)
}

/// `a / |a|`, as `a (1/|a|)`: one division and three products (one rounding more than
/// three divisions). Undefined (NaN) for a zero vector, as on paper and in nalgebra's
/// `normalize`.
pub fn normalize<A: Algebra>(alg: &mut A, a: Vec3<A::S>) -> Vec3<A::S> {
    let a = share3(alg, a, "v");
    let length = norm(alg, a.clone());
    let one = alg.num(1.0);
    let reciprocal = alg.div(one, length);
    let reciprocal = alg.share(reciprocal, "inverse_norm");
    a.map(|e| alg.mul(reciprocal.clone(), e))
}

/// The Hamilton product `p ⊗ q` (Solà eq. 12), in `[x, y, z, w]` storage.
pub fn compose<A: Algebra>(alg: &mut A, p: Quat<A::S>, q: Quat<A::S>) -> Quat<A::S> {
    let [px, py, pz, pw] = share4(alg, p, "lhs");
    let [qx, qy, qz, qw] = share4(alg, q, "rhs");
    // Each entry is a signed sum of four products.
    let mut sum = |terms: [(f64, &A::S, &A::S); 4]| {
        let mut total: Option<A::S> = None;
        for (sign, a, b) in terms {
            let product = alg.mul(a.clone(), b.clone());
            total = Some(match (total, sign > 0.0) {
                (None, true) => product,
                (None, false) => alg.neg(product),
                (Some(t), true) => alg.add(t, product),
                (Some(t), false) => alg.sub(t, product),
            });
        }
        total.expect("four terms")
    };
    [
        sum([
            (1.0, &pw, &qx),
            (1.0, &px, &qw),
            (1.0, &py, &qz),
            (-1.0, &pz, &qy),
        ]),
        sum([
            (1.0, &pw, &qy),
            (-1.0, &px, &qz),
            (1.0, &py, &qw),
            (1.0, &pz, &qx),
        ]),
        sum([
            (1.0, &pw, &qz),
            (1.0, &px, &qy),
            (-1.0, &py, &qx),
            (1.0, &pz, &qw),
        ]),
        sum([
            (1.0, &pw, &qw),
            (-1.0, &px, &qx),
            (-1.0, &py, &qy),
            (-1.0, &pz, &qz),
        ]),
    ]
}

/// The inverse of a unit quaternion: its conjugate (Solà eq. 24).
pub fn inverse<A: Algebra>(alg: &mut A, q: Quat<A::S>) -> Quat<A::S> {
    let [x, y, z, w] = q;
    [alg.neg(x), alg.neg(y), alg.neg(z), w]
}

/// The rotation matrix of a unit quaternion, row by row (Solà eq. 115), in the form that
/// assumes a unit norm: `1 - 2(y² + z²)` on the diagonal, `2(xy - wz)` and so on off it.
pub fn matrix<A: Algebra>(alg: &mut A, q: Quat<A::S>) -> [Vec3<A::S>; 3] {
    let [x, y, z, w] = share4(alg, q, "rotation");
    let two = alg.num(2.0);
    let one = alg.num(1.0);
    let mut twice = |a: &A::S, b: &A::S, hint: &str| {
        let ab = alg.mul(a.clone(), b.clone());
        let t = alg.mul(two.clone(), ab);
        alg.share(t, hint)
    };
    let (xx, yy, zz) = (
        twice(&x, &x, "two_xx"),
        twice(&y, &y, "two_yy"),
        twice(&z, &z, "two_zz"),
    );
    let (xy, xz, yz) = (
        twice(&x, &y, "two_xy"),
        twice(&x, &z, "two_xz"),
        twice(&y, &z, "two_yz"),
    );
    let (wx, wy, wz) = (
        twice(&w, &x, "two_wx"),
        twice(&w, &y, "two_wy"),
        twice(&w, &z, "two_wz"),
    );
    let mut diagonal = |a: &A::S, b: &A::S| {
        let sum = alg.add(a.clone(), b.clone());
        alg.sub(one.clone(), sum)
    };
    let (r00, r11, r22) = (diagonal(&yy, &zz), diagonal(&xx, &zz), diagonal(&xx, &yy));
    [
        [
            r00,
            alg.sub(xy.clone(), wz.clone()),
            alg.add(xz.clone(), wy.clone()),
        ],
        [alg.add(xy, wz), r11, alg.sub(yz.clone(), wx.clone())],
        [alg.sub(xz, wy), alg.add(yz, wx), r22],
    ]
}

/// `R v`: `v` rotated by `q`.
pub fn rotate<A: Algebra>(alg: &mut A, q: Quat<A::S>, v: Vec3<A::S>) -> Vec3<A::S> {
    let rows = matrix(alg, q);
    let v = share3(alg, v, "rotated");
    rows.map(|row| dot(alg, row, v.clone()))
}

/// `R' v`: `v` rotated by the inverse of `q`, on the same matrix entries as [`rotate`].
pub fn inverse_rotate<A: Algebra>(alg: &mut A, q: Quat<A::S>, v: Vec3<A::S>) -> Vec3<A::S> {
    let [r0, r1, r2] = matrix(alg, q);
    let v = share3(alg, v, "rotated");
    let [[a, b, c], [d, e, f], [g, h, i]] = [r0, r1, r2];
    [[a, d, g], [b, e, h], [c, f, i]].map(|column| dot(alg, column, v.clone()))
}

/// The exponential map `Exp(θ) = [sin(|θ|/2) θ/|θ|, cos(|θ|/2)]` (Solà eq. 101), exact
/// (not to first order) and total with no branch: `|θ|` is `n = sqrt(θ·θ + ε²)`
/// ([`ANGLE_EPSILON_SQUARED`]). The sine and cosine of one argument become one `sin_cos`
/// in the lowering.
///
/// - **Values.** `sin(n/2)/n` and `cos(n/2)` are even and flat in `n` at 0, so `n` in
///   place of `|θ|` moves them by less than rounding. At `θ = 0` they are `1/2` and `1`
///   exactly: the identity `[0, 0, 0, 1]`. (nalgebra's `from_scaled_axis` is a
///   first-order value below `|θ| = 2 f64::EPSILON`, 4.4e-16: the identity, vector part
///   0, not `θ/2`; its `from_axis_angle` is exact there and is the reference in tests.)
/// - **Jacobian at 0**, `[I/2; 0]` (`Jr(0) = I`), with no `0·∞`: the derivative of
///   `sin(n/2)/n` has the numerator `cos(n/2) n/2 - sin(n/2)`, exactly 0 there, over the
///   finite `n² = ε²`. Near 0 the quotient rule's two terms (each about `1/(2n)`) cancel;
///   the error is an ulp of them, multiplied by `θ_i θ_j / n ≤ n`: an ulp of `1/2` at most.
/// - **Second derivatives** divide by `n⁴ ≥ 1e-36`, normal in `f32`: finite everywhere.
///   At 0 they are exact to rounding (the cancelling term is multiplied by `θ = 0`). Near
///   0 it is not multiplied away: the error is a few ulps of `1/(2n)`, absolute, against
///   entries of about 1/4. Measured: in `f64` 5e-8 at `|θ| = 1e-9`, 2e-10 at 1e-6; in
///   `f32` 32 at 1e-9, 0.06 at 1e-6, 4e-4 at 1e-4, 1e-5 at 1e-2. A Taylor arm for small
///   `|θ|` would remove it.
pub fn exp<A: Algebra>(alg: &mut A, theta: Vec3<A::S>) -> Quat<A::S> {
    let theta = share3(alg, theta, "angle");
    let squared = dot(alg, theta.clone(), theta.clone());
    let epsilon = alg.num(ANGLE_EPSILON_SQUARED);
    let padded = alg.add(squared, epsilon);
    let root = alg.call(Func::Sqrt, padded);
    let angle = alg.share(root, "angle");
    let half = alg.num(0.5);
    let half_angle = alg.mul(half, angle.clone());
    let half_angle = alg.share(half_angle, "half_angle");
    let sine = alg.call(Func::Sin, half_angle.clone());
    let cosine = alg.call(Func::Cos, half_angle);
    let ratio = alg.div(sine, angle);
    let ratio = alg.share(ratio, "sin_half_angle_over_angle");
    let [x, y, z] = theta.map(|e| alg.mul(ratio.clone(), e));
    [x, y, z, cosine]
}

/// The logarithm `Log(q) = 2 atan2(|v|, w) v/|v|` (Solà eq. 105), `v` the vector part,
/// with `q` first taken to the hemisphere `w >= 0` so that `q` and `-q`, the same rotation,
/// give the same rotation vector, of length at most `π`: with `n = sqrt(v·v + ε²)` padded
/// as in [`exp`] and `k = 2 atan2(n, |w|)/n`, `Log(q) = (w < 0 ? -k : k) v`. Matches
/// nalgebra's `UnitQuaternion::scaled_axis`, which uses the same `atan2` and sign.
///
/// - **Half turn.** At `w = 0` exactly `q` and `-q` give opposite vectors, the two names
///   of that rotation; across `w = 0` the result jumps between them, as every logarithm
///   of SO(3) must somewhere.
/// - **Exact, not first order.** `atan2(n, |w|)/n` is even and flat in `n` at 0 (for
///   `|w| > 0`), so `ε` moves it by at most `ε²/(3w²)` relative, and by at most
///   `ε²/(2|v|²)`: below rounding for a unit `q`, whose `|w|` or `|v|` is at least 0.7.
///   At the identity the ratio is `2/|w|`, exact to rounding, and the derivative `[2I, 0]`;
///   near a half turn (`w ≈ 0`) `atan2` keeps full accuracy, where `2 acos(w)` would not.
/// - **Total.** `n ≥ ε`: no division by zero, whatever `q`; `Log(0) = 0`. `atan2` sees
///   only the ratio of `|v|` to `|w|`, so a non-unit `q` gives the log of `q/|q|` (for
///   `|v| ≫ ε`).
pub fn log<A: Algebra>(alg: &mut A, q: Quat<A::S>) -> Vec3<A::S> {
    let [x, y, z, w] = share4(alg, q, "rotation");
    let v = [x, y, z];
    let squared = dot(alg, v.clone(), v.clone());
    let epsilon = alg.num(ANGLE_EPSILON_SQUARED);
    let padded = alg.add(squared, epsilon);
    let root = alg.call(Func::Sqrt, padded);
    let length = alg.share(root, "sin_half_angle");
    let w_abs = alg.call(Func::Abs, w.clone());
    let half_angle = alg.atan2(length.clone(), w_abs);
    let two = alg.num(2.0);
    let angle = alg.mul(two, half_angle);
    let ratio = alg.div(angle, length);
    let ratio = alg.share(ratio, "angle_over_sin_half_angle");
    // The hemisphere's sign as a choice of `-k` or `k`: no product with `±1`.
    let (zero, minus_ratio) = (alg.num(0.0), alg.neg(ratio.clone()));
    let signed = alg.select(Comparison::Lt, w, zero, minus_ratio, ratio);
    let signed = alg.share(signed, "signed_angle_over_sin_half_angle");
    v.map(|e| alg.mul(signed.clone(), e))
}

/// One Newton step towards a unit norm, `q (3 - q·q) / 2`: it squares the norm's error
/// (from `1 + e` to `1 - 3e²/2 + ..`; the squared norm from `1 + s` to
/// `1 - 3s²/4 + s³/4`), so a rotation advanced every sample stays unit to rounding with
/// no square root or division.
pub fn renormalize<A: Algebra>(alg: &mut A, q: Quat<A::S>) -> Quat<A::S> {
    let q = share4(alg, q, "rotation");
    let [x, y, z, w] = q.clone();
    let vector = dot(alg, [x, y, z], [q[0].clone(), q[1].clone(), q[2].clone()]);
    let ww = alg.mul(w.clone(), w);
    let squared = alg.add(vector, ww);
    let (three, half) = (alg.num(3.0), alg.num(0.5));
    let deficit = alg.sub(three, squared);
    let factor = alg.mul(half, deficit);
    let factor = alg.share(factor, "norm_correction");
    q.map(|e| alg.mul(factor.clone(), e))
}
