//! Stress stage: constitutive updates from the nodal velocity field.
pub mod linear_elastic;
pub mod neo_hookean;
pub mod shock_viscosity;
