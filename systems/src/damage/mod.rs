//! Damage stage: failure and softening of material points.
pub mod eigenerosion;
pub mod eigensoftening;
pub mod softening;
pub mod stress_reach;
