//! Contact stage: interactions between the velocity fields of a node.

pub mod frictional;
pub mod frictional_law;
pub mod penalty;
pub mod penalty_law;
