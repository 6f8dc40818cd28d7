//! The symbolic engine: a hash-consed expression graph with simplification,
//! differentiation and substitution, and the lowering of a model into it.

pub mod continuous;
pub mod diff;
pub mod graph;
pub mod kalman;
pub mod linalg;
pub mod model_graph;
pub mod polynomial;
pub mod predictive;
pub mod riccati;
pub mod switched;
pub mod window;

pub use diff::Differentiator;
pub use graph::{Graph, Node, NodeId, VarId};
pub use model_graph::ModelGraph;
