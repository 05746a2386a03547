//! Corrector stage: nodal velocity correctors.
pub mod newmark;
