//! Basis stage: shape functions and particle–node connectivity.
pub mod linear;
