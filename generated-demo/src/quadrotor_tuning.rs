//! TinyMPC's quadrotor hover benchmark as its own repositories set it up: the weights
//! (`Q_data`, `R_data` of `examples/problem_data/quadrotor_20hz_params.hpp` in its C++
//! library, the same diagonals as its Python package's
//! `examples/quadrotor_hover_code_generation.py`), the input limits, the first state of
//! `examples/quadrotor_hovering.cpp` (as the error from its reference `z = 2`), and the
//! gust the closed-loop runs add. Shared by the embedded-QP benchmark (`cargo xtask
//! peers`) and the main job's quadrotor held within its limits.

/// The state weight's diagonal, `Q_data`.
pub const Q_DIAGONAL: [f32; 12] = [
    100.0,
    100.0,
    100.0,
    4.0,
    4.0,
    400.0,
    4.0,
    4.0,
    4.0,
    2.040_816_3,
    2.040_816_3,
    4.0,
];
/// The input weight's diagonal, `R_data`.
pub const R_DIAGONAL: [f32; 4] = [4.0; 4];
/// The input limits `|u| <= U_MAX` (`u_min`, `u_max` of `quadrotor_hovering.cpp`): the
/// motors' thrusts less the hover thrust.
pub const U_MAX: f32 = 0.5;
/// The first state less its reference (`z = 2`).
pub const FIRST: [f32; 12] = [0.0, 1.0, -2.0, 0.2, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.0, 0.0];
/// The gust: added to the velocities and attitude rates at [`GUST_STEP`], so the inputs
/// saturate again.
pub const GUST: [f32; 12] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.5, -1.0, 1.0, 1.0, -1.0, 0.5];
/// The sample at which the gust hits (of 200 at 20 Hz).
pub const GUST_STEP: usize = 100;
