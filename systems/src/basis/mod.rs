//! Basis stage: shape functions and particle–node connectivity.
pub mod gimp;
pub mod linear;
pub mod lme;
mod lme_graded;
pub mod lme_kernel;

use fractum_engine::prelude::*;
use fractum_engine::scene::budget::{connectivity_entry_bytes, describe_count};

/// Declares a basis's connectivity storage, `nodes` support nodes per particle, for the
/// scene's memory estimate. `stores_gradients`: whether each entry keeps its gradient (rows
/// whose gradients follow a per-row map, LME's eq. 8, count the map in `extra_bytes`).
pub fn declare_support(
    installer: &mut Installer,
    name: &str,
    nodes: f64,
    stores_gradients: bool,
    extra_bytes: f64,
) {
    let gradient = if stores_gradients {
        0.0
    } else {
        (8 * installer.dimension().count()) as f64
    };
    let entry = with_dim!(installer.dimension(), D => connectivity_entry_bytes::<D>()) - gradient;
    installer.declare_particle_memory(
        format!(
            "{name}: a support of about {} nodes per particle",
            describe_count(nodes)
        ),
        nodes * entry + extra_bytes,
    );
}
