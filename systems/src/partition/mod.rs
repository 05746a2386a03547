//! Partition stage: which velocity field each particle maps to at each node.

pub mod bodies;
pub mod dfg;
pub mod field_assignment;
