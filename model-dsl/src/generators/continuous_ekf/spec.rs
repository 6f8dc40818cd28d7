//! The continuous-time EKF's options, as checked.

use crate::emit::filter::ProcessNoise;

/// Options of the continuous-time EKF.
#[derive(Clone, Debug, Default)]
pub struct ContinuousEkfSpec {
    /// The process noise's shape: diagonal (stored and added as its variances) or a full
    /// symmetric matrix, on every state or on those `process_noise_on` lists.
    pub process_noise: ProcessNoise,
    /// The default prescribed degree of stability `alpha >= 0` (Reif et al.), if the
    /// filter has one: `F` is replaced by `F + alpha I` in its Riccati equation.
    pub alpha: Option<f64>,
    /// The innovation gate: a measurement whose normalised innovation squared (against
    /// `H P H' + R / T`) exceeds it is rejected as an outlier (`None`: no gate).
    pub gate: Option<f64>,
    /// Consecutive refused measurements after which a stage inflates its covariance and
    /// takes them again (`recover_after = N`; `None` for `off`), see
    /// [`crate::emit::recovery`].
    pub recover_after: Option<u32>,
}
