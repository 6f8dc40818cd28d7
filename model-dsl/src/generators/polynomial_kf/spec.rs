//! The polynomial Kalman filter's options, as checked.

use proc_macro2::Span;

/// Options of the polynomial Kalman filter.
#[derive(Clone, Debug)]
pub struct PolynomialKfSpec {
    /// Order `m` of the polynomial: the state has `m + 1` entries.
    pub order: usize,
    /// Sample period `T` \[s\], for the derivatives in physical units.
    pub dt: f64,
    /// Fading factor `f`: the process noise is `f I`.
    pub fading: f64,
    /// Measurement noise variance `sigma^2`.
    pub noise_variance: f64,
    /// Samples between re-initialisations from the window fit.
    pub reinit_every: u32,
    /// Samples in the least-squares window.
    pub window: usize,
    /// The innovation gate (`gate = ..`), if any.
    pub gate: Option<f64>,
    /// Where `polynomial_kf` was written, for errors about the model.
    pub span: Span,
}
