//! Basis stage: shape functions and particle–node connectivity.
pub mod linear;
pub mod lme;
pub mod lme_kernel;
