//! The switched observers of a piecewise-linear model.

pub mod design;
pub mod lower;
