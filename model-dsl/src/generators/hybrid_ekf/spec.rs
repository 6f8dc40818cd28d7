//! The hybrid EKF's options, as checked.

/// Options of the hybrid (continuous-discrete) EKF.
#[derive(Clone, Debug, Default)]
pub struct HybridEkfSpec {
    /// Whether the process noise spectral density is diagonal.
    pub diagonal_noise: bool,
    /// The innovation gate: a measurement whose normalised innovation squared exceeds it
    /// is rejected as an outlier (`None`: no gate is generated).
    pub gate: Option<f64>,
}
