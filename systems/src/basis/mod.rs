//! Basis stage: shape functions and particle–node connectivity.
pub mod bspline;
pub mod gimp;
pub mod linear;
pub mod lme;
mod lme_graded;
pub mod lme_kernel;
pub mod lme_lanes;
pub mod lme_rows;
pub mod mls;
pub mod tensor;

use fractum_engine::budget::{connectivity_entry_bytes, describe_count};
use fractum_engine::prelude::*;

/// Half the side of the square (cubic) domain of a particle of `volume` (per `thickness` in 2D;
/// pass 1 in 3D): `½ (V/t)^{1/d}`. GIMP's particle domain, and the contact laws' particle
/// width.
pub fn domain_half_width(volume: f64, thickness: f64, dimensions: usize) -> f64 {
    0.5 * (volume / thickness).powf(1.0 / dimensions as f64)
}

/// Declares a basis's connectivity storage, `nodes` support nodes per particle, for the
/// scene's memory estimate, and its support radius, `radius_cells` cell widths, for a
/// distributed run's halo. `stores_gradients`: whether each entry keeps its gradient (rows
/// whose gradients follow a per-row map, LME's eq. 8, count the map in `extra_bytes`).
pub fn declare_support<D: Dim>(
    installer: &mut Installer,
    name: &str,
    (nodes, radius_cells): (f64, f64),
    stores_gradients: bool,
    extra_bytes: f64,
) {
    // In the widest cell, so that no support on a graded grid reaches further.
    let grid = installer.world().resource::<Grid<D>>();
    let widest = (0..D::N)
        .flat_map(|a| (0..grid.cells[a]).map(move |i| grid.cell_width(a, i)))
        .fold(0.0, f64::max);
    installer.declare_support_radius(radius_cells * widest);
    let gradient = if stores_gradients {
        0.0
    } else {
        (8 * D::N) as f64
    };
    let entry = connectivity_entry_bytes::<D>() - gradient;
    installer.declare_particle_memory(
        format!(
            "{name}: a support of about {} nodes per particle",
            describe_count(nodes)
        ),
        nodes * entry + extra_bytes,
    );
}
