//! The double Kalman filter's options, as checked.

/// Options of the double Kalman filter.
#[derive(Clone, Debug)]
pub struct DkfSpec {
    /// Weight of the split of each state-parameter product, eq. (12).
    pub eta: f64,
    /// The innovation gate both filters test their normalised innovation squared
    /// against (`gate = ..`), if any.
    pub gate: Option<f64>,
    /// Whether both process noise covariances (AKF's and LKF's) are diagonal.
    pub diagonal_noise: bool,
    /// The output samples the window holds (`window = ..`) and where it was written, if
    /// given: longer than the minimum, the parameter system is solved by least squares.
    pub window: Option<(usize, proc_macro2::Span)>,
    /// Where `dkf` was written, for errors of the window transform.
    pub span: proc_macro2::Span,
    /// Consecutive refused measurements after which a stage inflates its covariance and
    /// takes them again (`recover_after = N`; `None` for `off`), see
    /// [`crate::emit::recovery`].
    pub recover_after: Option<u32>,
}
