//! The extended Kalman filter's options, as checked.

/// Options of the extended Kalman filter.
#[derive(Clone, Debug, Default)]
pub struct EkfSpec {
    /// The generated type's name, `Ekf` unless `name = ..` is given.
    pub type_name: String,
    /// Whether the process noise covariance is diagonal (stored and added as its
    /// diagonal only), rather than a full symmetric matrix.
    pub diagonal_noise: bool,
    /// The innovation gate: a measurement whose normalised innovation squared exceeds it
    /// is rejected as an outlier (`None`: no gate is generated).
    pub gate: Option<f64>,
}
