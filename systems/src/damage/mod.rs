//! Damage stage: failure and softening of material points.
pub mod eigenerosion;
pub mod eigensoftening;
pub mod rankine;
pub mod softening;
pub mod stress_reach;
pub mod tensile_degradation;
pub mod time_to_failure;
pub mod weibull;
