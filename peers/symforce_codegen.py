"""SymForce's C++ code generation for the 24-state navigation EKF: the benchmark's peer of
the generated `navigation::Ekf` (`generated-demo/models/navigation.rs`), run by `cargo
xtask peers` (and `cargo xtask cost`) in the venv it makes under target/peers.

The same model derived with SymForce (its symbolic API, `codegen.Codegen.function` with
`codegen.CppConfig()`), three functions of `Scalar`, each reading and writing the
covariance as its packed upper triangle, row by row (300 entries: (0,0), (0,1), ..,
(0,23), (1,1), .., (23,23): the generated filter's own order), so that the generated code
reads and writes only the triangle:

- `NavigationPredict(x, p, u, q)`: `x_new = f(x, u)` as navigation.rs writes `f`, and
  `P_new = A P A' + diag(q)` with `A = df/dx`;
- `NavigationUpdateGnss(x, p, y, r)` and `NavigationUpdateMagnetometer(x, p, y, r)`:
  the sensor's fusion as sequential scalar updates, PX4 EKF2's scheme (`r` the
  diagonal of the sensor's R): `H = dh/dx` at the prior `x0`; for each output `a` in turn,
  `r_a = y_a - h_a(x0) - H_a (x_(a-1) - x0)`, `u = P_(a-1) H_a'`, `s = H_a u + R_aa`,
  `K = u / s`, `x_a = x_(a-1) + K r_a`, `P_a = P_(a-1) - K u'`. With a diagonal R this
  equals the joint update in exact arithmetic; the residual's linear term makes it so for
  the nonlinear magnetometer too (every output linearised at the prior, as the joint
  update does). Of the formulations tried it gave SymForce the fewest operations (a
  joint update with a symbolic 3x3 inverse took more).

The model's constants (DT, GRAVITY) come from the Rust model through the JSON file xtask
writes (`navigation.json`), so the two cannot disagree.

    python symforce_codegen.py navigation.json out_dir

writes `out_dir/symforce/*.h` and prints one line: the version and each function's
operation count as SymForce states it.
"""

import json
import re
import sys
from pathlib import Path

import symforce

# Before the symbolic API is imported, as SymForce asks; no function here uses epsilon
# (no division or square root it would guard), so the generated code is the same, and
# SymForce no longer warns that epsilon is zero.
symforce.set_epsilon_to_symbol()

import symforce.symbolic as sf  # noqa: E402
from symforce import codegen  # noqa: E402

N = 24


def unpacked(p):
    """The symmetric 24x24 matrix of a packed upper triangle."""
    full = sf.Matrix.zeros(N, N)
    k = 0
    for i in range(N):
        for j in range(i, N):
            full[i, j] = full[j, i] = p[k]
            k += 1
    return full


def packed(m):
    """The packed upper triangle of a symmetric 24x24 matrix."""
    return sf.Matrix([m[i, j] for i in range(N) for j in range(i, N)])


def dynamics(constants):
    """`f(x, u)` exactly as the model's `dynamics discrete` block writes it (every right-hand
    side in terms of the previous state)."""
    dt, gravity = constants["dt"], constants["gravity"]

    def f(x, u):
        q0, q1, q2, q3, vn, ve, vd, pn, pe, pd = (x[i] for i in range(10))
        dax_b, day_b, daz_b, dvx_b, dvy_b, dvz_b = (x[10 + i] for i in range(6))
        dax, day, daz, dvx, dvy, dvz = (u[i] for i in range(6))
        da_x, da_y, da_z = dax - dax_b, day - day_b, daz - daz_b
        dv_x, dv_y, dv_z = dvx - dvx_b, dvy - dvy_b, dvz - dvz_b
        new = [
            q0 - 0.5 * (q1 * da_x + q2 * da_y + q3 * da_z),
            q1 + 0.5 * (q0 * da_x + q2 * da_z - q3 * da_y),
            q2 + 0.5 * (q0 * da_y - q1 * da_z + q3 * da_x),
            q3 + 0.5 * (q0 * da_z + q1 * da_y - q2 * da_x),
            vn
            + (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3) * dv_x
            + 2.0 * (q1 * q2 - q0 * q3) * dv_y
            + 2.0 * (q1 * q3 + q0 * q2) * dv_z,
            ve
            + 2.0 * (q1 * q2 + q0 * q3) * dv_x
            + (q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3) * dv_y
            + 2.0 * (q2 * q3 - q0 * q1) * dv_z,
            vd
            + 2.0 * (q1 * q3 - q0 * q2) * dv_x
            + 2.0 * (q2 * q3 + q0 * q1) * dv_y
            + (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3) * dv_z
            + gravity * dt,
            pn + dt * vn,
            pe + dt * ve,
            pd + dt * vd,
        ]
        # The biases, fields and wind are random walks.
        return sf.Matrix(new + [x[i] for i in range(10, N)])

    return f


def gnss(x):
    """The GNSS outputs: NED velocity and position (states 4..9)."""
    return sf.Matrix([x[4 + i] for i in range(6)])


def magnetometer(x):
    """The magnetometer outputs as navigation.rs writes them: the earth field rotated to
    the body, `R(q)' m_earth`, plus the body bias."""
    q0, q1, q2, q3 = (x[i] for i in range(4))
    mag_n, mag_e, mag_d, mag_bx, mag_by, mag_bz = (x[16 + i] for i in range(6))
    return sf.Matrix(
        [
            (q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3) * mag_n
            + 2.0 * (q1 * q2 + q0 * q3) * mag_e
            + 2.0 * (q1 * q3 - q0 * q2) * mag_d
            + mag_bx,
            2.0 * (q1 * q2 - q0 * q3) * mag_n
            + (q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3) * mag_e
            + 2.0 * (q2 * q3 + q0 * q1) * mag_d
            + mag_by,
            2.0 * (q1 * q3 + q0 * q2) * mag_n
            + 2.0 * (q2 * q3 - q0 * q1) * mag_e
            + (q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3) * mag_d
            + mag_bz,
        ]
    )


def sequential_update(x, p, y, r, h):
    """The sensor's outputs fused one at a time (see the module's doc)."""
    cov = unpacked(p)
    prior = sf.Matrix(x)
    estimate = sf.Matrix(x)
    predicted = h(prior)
    jacobian = predicted.jacobian(prior)
    for a in range(y.shape[0]):
        row = jacobian[a, :]
        u = cov * row.T
        s = (row * u)[0, 0] + r[a]
        gain = u / s
        residual = y[a] - predicted[a] - (row * (estimate - prior))[0, 0]
        estimate = estimate + gain * residual
        cov = cov - gain * u.T
    return estimate, packed(cov)


def functions(constants):
    """The three functions, with the argument types SymForce generates them for."""
    f = dynamics(constants)

    def navigation_predict(
        x: sf.M(N, 1), p: sf.M(N * (N + 1) // 2, 1), u: sf.M(6, 1), q: sf.M(N, 1)
    ):
        x_new = f(x, u)
        a = x_new.jacobian(x)
        noise = sf.Matrix.diag([q[i] for i in range(N)])
        return x_new, packed(a * unpacked(p) * a.T + noise)

    def navigation_update_gnss(
        x: sf.M(N, 1), p: sf.M(N * (N + 1) // 2, 1), y: sf.M(6, 1), r: sf.M(6, 1)
    ):
        return sequential_update(x, p, y, r, gnss)

    def navigation_update_magnetometer(
        x: sf.M(N, 1), p: sf.M(N * (N + 1) // 2, 1), y: sf.M(3, 1), r: sf.M(3, 1)
    ):
        return sequential_update(x, p, y, r, magnetometer)

    return [navigation_predict, navigation_update_gnss, navigation_update_magnetometer]


def main():
    constants = json.load(open(sys.argv[1]))
    if constants["states"] != N:
        sys.exit(f"the model has {constants['states']} states; this derivation is for {N}")
    out = Path(sys.argv[2]) / "symforce"
    counts = []
    for function in functions(constants):
        generated = codegen.Codegen.function(
            func=function, config=codegen.CppConfig(), output_names=["x_new", "p_new"]
        )
        generated.generate_function(output_dir=out, skip_directory_nesting=True)
        header = (out / f"{function.__name__}.h").read_text()
        ops = re.search(r"// Total ops: (\d+)", header)
        counts.append(f"{function.__name__} {ops.group(1) if ops else '?'} ops")
    print(f"symforce {symforce.__version__}: " + ", ".join(counts))


if __name__ == "__main__":
    main()
