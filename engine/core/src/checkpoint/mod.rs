//! Checkpoints: the state a run carries from one step to the next, captured so that a run
//! continued from it takes bitwise the same steps as one that never stopped.
//!
//! What is state is declared, not guessed. [`CheckpointState`] lists every component and
//! resource a checkpoint carries:
//! - the engine registers the particles' own components and its running totals (the energy
//!   account and watch, the force probes' memory, the removed particles, the published
//!   columns) when it builds a scene;
//! - every component a system gives particles through
//!   [`crate::registry::Installer::add_particle_component`] is registered by that call, so a
//!   system cannot add per-particle data that a checkpoint forgets;
//! - a system's resource that carries values between steps (a warm start, a cached neighbour
//!   list, a running total) is installed with [`crate::registry::Installer::insert_state`] or
//!   [`crate::registry::Installer::init_state`].
//!
//! Everything else is rebuilt from the scene (grid, materials, parameters) or recomputed by
//! every step before it is read (nodal fields, connectivity, scratch buffers). Particles are
//! matched by [`ParticleId`](crate::components::ParticleId); particles removed on leaving the grid are removed again in the
//! order they went, so the storage order, and with it every sum's order, is the original.
//!
//! - `keys.rs`: what can be carried ([`State`], [`RowState`]) and the keys of the engine's
//!   own state; [`state`]: what a world carries ([`CheckpointState`]) and the capture and
//!   restore of a world;
//! - the checkpoint file (format, digest, names, writing and reading) and resuming a run from
//!   it belong to `fractum-io` (`fractum_io::checkpoint`, `fractum_io::run::resume_from`).

mod codecs;
mod keys;
pub mod state;

pub use keys::*;
pub use state::*;
