//! Predictor stage: particle-to-grid transfer and the nodal velocity predictor.
pub mod newmark;
pub mod usl;
