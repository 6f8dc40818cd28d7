//! The adaptive LQR's options, as checked.

/// Options of the adaptive LQR.
#[derive(Clone, Debug)]
pub struct LqrSpec {
    /// Steps of the backward Riccati recursion.
    pub horizon: u32,
    /// The physical states it regulates, by index into [`crate::model::Model::states`].
    pub states: Vec<usize>,
    /// The inputs it computes, by index into [`crate::model::Model::inputs`].
    pub inputs: Vec<usize>,
}
