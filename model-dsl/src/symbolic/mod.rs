//! The symbolic engine: a hash-consed expression graph with simplification,
//! differentiation and substitution, and the lowering of a model into it.

pub mod continuous;
pub mod covariance_blocks;
pub mod diff;
pub mod error_state;
pub mod euler_state;
pub mod geometry;
pub mod graph;
pub mod kalman;
pub mod linalg;
pub mod measurement_terms;
pub mod model_graph;
pub mod riccati;
pub mod scaled_covariance;

pub use diff::Differentiator;
pub use graph::{loop_invariant_operands, substitute, Graph, Node, NodeId, VarId};
pub use model_graph::ModelGraph;
