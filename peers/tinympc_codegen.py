"""TinyMPC's code generation for the blade's MPC: the benchmark's peer, run by
`cargo xtask peers` (and `cargo xtask cost`) in the venv it makes under target/peers.

TinyMPC (ADMM with a cached infinite-horizon Riccati gain) takes a fixed model: its
cache (Kinf, Pinf, C1, C2) is computed here, on the host, and cannot be recomputed on the
target. It is handed the generated MPC's problem at the first step: the prediction
model (A, B) at the first estimate (1/m = 5, unchanged until the mass change at step
150, after which the generated MPC's model differs from TinyMPC's), Q = diag(1, 0),
R = 1e-10 (both times 1/R = 1e10, as OSQP's objective), N = 11 knot points (10 moves),
input bounds +-100 V. Its terminal weight is its own cached Pinf (of the rho-augmented
problem), not the generated MPC's Riccati-iterated P_f.

    python tinympc_codegen.py problem.json out_dir
"""

import json
import sys

import numpy as np
import tinympc

RHO = 1.0
SETTINGS = dict(abs_pri_tol=1e-3, abs_dua_tol=1e-3, max_iter=500, check_termination=1)


def main():
    problem = json.load(open(sys.argv[1]))
    out = sys.argv[2]
    step = problem["steps"][0]
    scale = 1.0 / float(problem["r"][0][0])
    a = np.array(step["a"], dtype=float)
    b = np.array(step["b"], dtype=float)
    q = np.diag(np.array(problem["q"], dtype=float)) * scale
    r = np.array([float(problem["r"][0][0]) * scale])
    u_max = float(problem["u_max"])
    n = problem["horizon"] + 1
    solver = tinympc.TinyMPC()
    solver.setup(a, b, np.diag(q), np.diag(r), n, rho=RHO,
                 u_min=-u_max * np.ones((1, n - 1)), u_max=u_max * np.ones((1, n - 1)),
                 **SETTINGS)
    solver.codegen(f"{out}/tinympc")
    print("tinympc", "rho", RHO, "settings", SETTINGS)


if __name__ == "__main__":
    main()
