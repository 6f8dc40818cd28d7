//! The switched observers' options, as checked.

use proc_macro2::Span;

/// Options of the switched observers (per-regime gains designed at generation time).
#[derive(Clone, Debug)]
pub struct SwitchedObserverSpec {
    /// Diagonal of the process noise covariance `Q`, one entry per state.
    pub process_noise: Vec<f64>,
    /// Diagonal of the measurement noise covariance `R`, one entry per output.
    pub measurement_noise: Vec<f64>,
    /// The gain `K1` of the first regime (row-major, states x outputs), if given; else it
    /// is regime 1's steady-state Kalman gain.
    pub k1: Option<Vec<f64>>,
    /// Where `switched_observer` was written.
    pub span: Span,
    /// Where the noise covariances were written (errors of the Kalman designs).
    pub noise_span: Span,
    /// Where `k1` was written, if it was (errors of the linear-error-dynamics design).
    pub k1_span: Option<Span>,
}
