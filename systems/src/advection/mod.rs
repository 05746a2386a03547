//! Advection stage: grid-to-particle transfer and particle motion.
pub mod newmark;
pub mod usl;

use serde::Deserialize;

/// The grid-to-particle transfer of an advection system (its `transfer` parameter).
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
pub enum Transfer {
    /// The particle velocity takes the grid's change (both papers' update).
    #[default]
    Flip,
    /// The affine particle-in-cell transfer: the particle takes the grid velocity and an affine
    /// velocity ([`fractum_engine::prelude::AffineVelocity`]), and the transfers keep angular
    /// momentum (`transfer::affine_interpolation`).
    Apic,
}
