"""SymForce's C++ code generation for the 24-entry error-state navigation EKF: the
benchmark's peer of the generated `navigation::Ekf` (`generated-demo/models/navigation.rs`),
run by `cargo xtask peers` (and `cargo xtask cost`) in the venv it makes under target/peers.

The same model derived with SymForce's geometry, as PX4 EKF2's current derivation
(`ekf_derivation/derivation.py`) does: the state a `Values` whose attitude is an `sf.Rot3`
(stored `[x, y, z, w]`, as ours), the covariance over its 23 tangent coordinates with a
global angular error (the true attitude is `Rot3.from_tangent(δθ) * q`), each Jacobian
taken in that tangent space at zero error by perturbing the state (PX4's small-angle
error quaternion `[δθ/2, 1]`, exact to first order, hence exact at zero). Three
functions of `Scalar`, each reading and writing the covariance as its packed upper
triangle, row by row (276 entries: (0,0), (0,1), .., (0,22), (1,1), .., (22,22): the
generated filter's own order), so that the generated code reads and writes only the
triangle:

- `NavigationPredict(x, p, u, q, dt)`: `x_new = f(x, u)` over the IMU sample's interval
  `dt`, the attitude turned by the exact `Rot3.from_tangent((gyro - gyro_bias) dt)`, and
  `P_new = F P F' + diag(q) dt` (`q` a density, as EKF2 scales its noise by the interval)
  with `F = d(f(x ⊞ δx) ⊟ f(x))/dδx` at `δx = 0`;
- `NavigationUpdateGnss(x, p, y, r)` and `NavigationUpdateMagnetometer(x, p, y, r)`: the
  sensor's fusion as sequential scalar updates of the error `δx` (zero before them), PX4
  EKF2's scheme (`r` the diagonal of the sensor's R): `H = d h(x ⊞ δx)/dδx` at `δx = 0`
  (the chain rule through the rotation's tangent); for each output `a` in turn,
  `r_a = y_a - h_a(x) - H_a δx_(a-1)`, `u = P_(a-1) H_a'`, `s = H_a u + R_aa`,
  `K = u / s`, `δx_a = δx_(a-1) + K r_a`, `P_a = P_(a-1) - K u'`. With a diagonal R this
  equals the joint update in exact arithmetic (every output linearised at the prior, as
  the joint update does). Then the error moves into the estimate, the attitude as
  `Rot3.from_tangent(δθ) * q`, and the covariance is reset, `G P G'` with
  `G = I + [δθ/2]x` on the attitude block (Solà 2017, sect. 7, global errors).

Each new attitude is renormalised by one Newton step, `q (3 - q.q) / 2`, as ours is.
The model's constants (GRAVITY, the exponential map's epsilon) come from the Rust
model through the JSON file xtask writes (`navigation.json`), so the two cannot disagree.

    python symforce_codegen.py navigation.json out_dir

writes `out_dir/symforce/*.h` and prints one line: the version and each function's
operation count as SymForce states it.
"""

import json
import re
import sys
from pathlib import Path

import symforce

# Before the symbolic API is imported, as SymForce asks; every function here passes the
# model's own epsilon to the exponential map, so none depends on SymForce's.
symforce.set_epsilon_to_symbol()

import symforce.symbolic as sf  # noqa: E402
from symforce import codegen  # noqa: E402
from symforce.values import Values  # noqa: E402

# The state's entries and the tangent's coordinates, in the Rust model's order: a key's
# storage size and its tangent size (the attitude's 4 and 3).
KEYS = [
    ("q", 4, 3),
    ("v", 3, 3),
    ("p", 3, 3),
    ("gyro_bias", 3, 3),
    ("accel_bias", 3, 3),
    ("mag_earth", 3, 3),
    ("mag_body", 3, 3),
    ("wind", 2, 2),
]
N_X = sum(size for _, size, _ in KEYS)
N = sum(tangent for _, _, tangent in KEYS)
PACKED = N * (N + 1) // 2


def unpacked(p):
    """The symmetric NxN matrix of a packed upper triangle."""
    full = sf.Matrix.zeros(N, N)
    k = 0
    for i in range(N):
        for j in range(i, N):
            full[i, j] = full[j, i] = p[k]
            k += 1
    return full


def packed(m):
    """The packed upper triangle of a symmetric NxN matrix."""
    return sf.Matrix([m[i, j] for i in range(N) for j in range(i, N)])


def state_of(x):
    """The state vector `x` as `Values`, the attitude an `sf.Rot3` ([x, y, z, w])."""
    state = Values()
    at = 0
    for key, size, _ in KEYS:
        entries = [x[at + i] for i in range(size)]
        state[key] = sf.Rot3.from_storage(entries) if key == "q" else sf.Matrix(entries)
        at += size
    return state


def storage(state):
    """The state vector of `Values` (the attitude's storage is [x, y, z, w])."""
    return sf.Matrix(state.to_storage())


def split(delta):
    """A tangent vector by key."""
    parts, at = {}, 0
    for key, _, tangent in KEYS:
        parts[key] = sf.Matrix([delta[at + i] for i in range(tangent)])
        at += tangent
    return parts


def perturbed(state, delta):
    """`x ⊞ δx` to first order: the attitude `[δθ/2, 1] * q` (PX4's small-angle error
    quaternion, global), the rest `x + δx`; exact in its value and first derivative at
    `δx = 0`, which is all a Jacobian there reads."""
    parts = split(delta)
    truth = Values()
    for key, _, _ in KEYS:
        if key == "q":
            error = sf.Rot3(sf.Quaternion(xyz=parts["q"] / 2, w=1))
            truth[key] = error * state[key]
        else:
            truth[key] = state[key] + parts[key]
    return truth


def error(truth, nominal):
    """`truth ⊟ nominal` to first order: the attitude's `2 vec(q_t * conj(q))` (the
    rotation vector of `q_t q^-1` to first order, PX4's), the rest the difference."""
    parts = []
    for key, _, _ in KEYS:
        if key == "q":
            turn = truth[key].q * nominal[key].q.conj()
            parts.extend(2 * turn.xyz)
        else:
            parts.extend(truth[key] - nominal[key])
    return sf.Matrix(parts)


def tangent_jacobian(function, state):
    """`d function(x ⊞ δx)/dδx` at `δx = 0`."""
    delta = sf.Matrix([sf.Symbol(f"delta{i}") for i in range(N)])
    value = function(perturbed(state, delta))
    jacobian = value.jacobian(delta)
    return jacobian.subs({d: 0 for d in delta})


def renormalised(rotation):
    """One Newton step towards a unit norm, `q (3 - q.q) / 2`, as ours takes."""
    q = rotation.q
    factor = (3 - (q.xyz.squared_norm() + q.w * q.w)) / 2
    return sf.Rot3(sf.Quaternion(xyz=q.xyz * factor, w=q.w * factor))


def dynamics(constants):
    """`f(x, u)` over the interval `dt` as the model's `dynamics discrete` block writes it
    (every right-hand side in terms of the previous state), the attitude before its
    renormalisation."""
    gravity, epsilon = constants["gravity"], constants["epsilon"]

    def f(state, u, dt):
        gyro = sf.V3(u[0], u[1], u[2]) - state["gyro_bias"]
        accel = sf.V3(u[3], u[4], u[5]) - state["accel_bias"]
        new = state.copy()
        q = state["q"]
        new["q"] = q * sf.Rot3.from_tangent(gyro * dt, epsilon=epsilon)
        new["v"] = state["v"] + (q * accel + sf.V3(0, 0, gravity)) * dt
        new["p"] = state["p"] + state["v"] * dt
        return new

    return f


def gnss(state):
    """The GNSS outputs: NED velocity and position."""
    return sf.Matrix(list(state["v"]) + list(state["p"]))


def magnetometer(state):
    """The magnetometer: the earth field rotated to the body plus the body bias."""
    return state["q"].inverse() * state["mag_earth"] + state["mag_body"]


def injected(state, dx, epsilon):
    """The error `dx` moved into the estimate: `Rot3.from_tangent(δθ) * q` (renormalised),
    the rest `x + δx`."""
    parts = split(dx)
    new = Values()
    for key, _, _ in KEYS:
        if key == "q":
            turn = sf.Rot3.from_tangent(parts["q"], epsilon=epsilon)
            new[key] = renormalised(turn * state[key])
        else:
            new[key] = state[key] + parts[key]
    return new


def reset(cov, dx):
    """`G P G'`, `G` the identity but for the attitude block `I + [δθ/2]x`."""
    g = sf.Matrix.eye(N)
    g[0:3, 0:3] = sf.Matrix.eye(3) + sf.Rot3.hat(sf.V3(dx[0], dx[1], dx[2]) / 2)
    return g * cov * g.T


def sequential_update(constants, x, p, y, r, h):
    """The sensor's outputs fused one at a time (see the module's doc)."""
    state = state_of(x)
    cov = unpacked(p)
    predicted = h(state)
    jacobian = tangent_jacobian(h, state)
    dx = sf.Matrix.zeros(N, 1)
    for a in range(y.shape[0]):
        row = jacobian[a, :]
        u = cov * row.T
        s = (row * u)[0, 0] + r[a]
        gain = u / s
        residual = y[a] - predicted[a] - (row * dx)[0, 0]
        dx = dx + gain * residual
        cov = cov - gain * u.T
    new = injected(state, dx, constants["epsilon"])
    return storage(new), packed(reset(cov, dx))


def functions(constants):
    """The three functions, with the argument types SymForce generates them for."""
    f = dynamics(constants)

    def navigation_predict(
        x: sf.M(N_X, 1), p: sf.M(PACKED, 1), u: sf.M(6, 1), q: sf.M(N, 1), dt: sf.Scalar
    ):
        state = state_of(x)
        nominal = f(state, u, dt)
        transition = tangent_jacobian(lambda truth: error(f(truth, u, dt), nominal), state)
        noise = sf.Matrix.diag([q[i] * dt for i in range(N)])
        new = nominal.copy()
        new["q"] = renormalised(nominal["q"])
        p_new = transition * unpacked(p) * transition.T + noise
        return storage(new), packed(p_new)

    def navigation_update_gnss(
        x: sf.M(N_X, 1), p: sf.M(PACKED, 1), y: sf.M(6, 1), r: sf.M(6, 1)
    ):
        return sequential_update(constants, x, p, y, r, gnss)

    def navigation_update_magnetometer(
        x: sf.M(N_X, 1), p: sf.M(PACKED, 1), y: sf.M(3, 1), r: sf.M(3, 1)
    ):
        return sequential_update(constants, x, p, y, r, magnetometer)

    return [navigation_predict, navigation_update_gnss, navigation_update_magnetometer]


def main():
    constants = json.load(open(sys.argv[1]))
    if (constants["states"], constants["tangent"]) != (N_X, N):
        sys.exit(
            f"the model has {constants['states']} entries over {constants['tangent']} "
            f"tangent coordinates; this derivation is for {N_X} over {N}"
        )
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
