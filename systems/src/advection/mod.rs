//! Advection stage: grid-to-particle transfer and particle motion.
pub mod newmark;
pub mod usl;
