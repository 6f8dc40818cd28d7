//! The extended Kalman filter's options, as checked.

use crate::emit::filter::ProcessNoise;

/// Options of the extended Kalman filter.
#[derive(Clone, Debug, Default)]
pub struct EkfSpec {
    /// The generated type's name, `Ekf` unless `name = ..` is given.
    pub type_name: String,
    /// The process noise's shape: diagonal (stored and added as its variances) or a full
    /// symmetric matrix, on every state or on those `process_noise_on` lists.
    pub process_noise: ProcessNoise,
    /// The inputs' entries whose noise enters the state through the input Jacobian
    /// (`input_noise = [gyro]`, a vector as its three), by index among the model's inputs,
    /// in the order their noise `qu` is given (variances per sample, or densities with a
    /// sample interval); empty without the option.
    pub input_noise: Vec<usize>,
    /// The innovation gate: a measurement whose normalised innovation squared exceeds it
    /// is rejected as an outlier (`None`: no gate is generated).
    pub gate: Option<f64>,
    /// Consecutive refused measurements after which a stage inflates its covariance and
    /// takes them again (`recover_after = N`; `None` for `off`), see
    /// [`crate::emit::recovery`].
    pub recover_after: Option<u32>,
    /// `horizon = current`: the filter fuses each measurement when it is given, as if it
    /// were current, whatever delay its sensor declares (what a filter without a delayed
    /// horizon does; for comparison). `false` by default: a model with a delayed sensor
    /// gets the delayed horizon.
    pub fuses_late_as_current: bool,
    /// Where the `generate ekf` item is, for the design's errors.
    pub item: Option<proc_macro2::Span>,
}
