//! Basis stage: shape functions and particle–node connectivity.
pub mod gimp;
pub mod linear;
pub mod lme;
pub mod lme_kernel;
