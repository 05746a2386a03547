//! The quadratic B-spline stencils of MLS-MPM, located, not tabulated.
//!
//! - Stage: basis. Registration name: `basis/mls`. Pairs with `predictor/mls`.
//! - Each particle's stencil is the three nodes per axis from `⌊ξ − ½⌋` of `basis/bspline`'s
//!   quadratic splines (order 2, with its folded splines at the grid's faces). This system
//!   finds the row of each particle's first node along the last axis and orders the particles
//!   by slab of [`SLAB_ROWS`] rows (a stable counting sort): the order of `predictor/mls`'s
//!   parallel scatter, in which no two slabs that run at once share a node.
//! - The weights are not stored: `predictor/mls` evaluates them in each transfer, a few
//!   multiplications per axis, which costs less than writing and reading back a table of
//!   weights and gradients per particle–node pair (the connectivity the other bases fill). So
//!   there is no connectivity, and the systems that need one are refused beside it.
//! - Needs a uniform grid of at least two cells along each axis.

use crate::predictor::mls_kernel::{Lattice, SLAB_ROWS, SlabOrder, StencilOrigin, locate};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `basis/mls`.
pub const REGISTRATION: Registration = Registration {
    name: "basis/mls",
    summary: "quadratic B-spline stencils for predictor/mls: each particle located and ordered \
              by slab; the weights are evaluated in the transfers, no connectivity",
    params: &[],
    requires: &["predictor/mls"],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    let grid = installer.world().resource::<Grid<D>>();
    if grid.is_graded() {
        return Err(params.error(
            "",
            "basis/mls needs a uniform grid (this scene's grid has `refine` intervals): its \
             splines are the cardinal ones of one spacing",
        ));
    }
    if (0..D::N).any(|a| grid.cells[a] < 2) {
        return Err(params.error(
            "",
            "basis/mls needs at least two cells along each axis of the grid (three nodes per \
             axis of its quadratic stencil)",
        ));
    }
    let reach = 1.5 * grid.spacing;
    installer.declare_support_radius(reach);
    let bytes = std::mem::size_of::<StencilOrigin<D>>() + 8;
    installer.declare_particle_memory(
        "basis/mls: each particle's stencil origin and slab order",
        bytes as f64,
    );
    installer.insert_resource(MlsStencils::<D>::default());
    installer.add_systems(mls_basis::<D>);
    Ok(())
}

/// Each particle's stencil origin and row (of its first node along the last axis), and the
/// particles in slab order.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct MlsStencils<D: Dim> {
    /// Stencil origin of each particle ([`StencilOrigin::OUTSIDE`] outside the grid).
    pub origins: Vec<StencilOrigin<D>>,
    /// Row of each particle (`u32::MAX` outside the grid).
    pub rows: Vec<u32>,
    /// Particles by slab.
    pub order: SlabOrder,
}

impl<D: Dim> Default for MlsStencils<D> {
    fn default() -> Self {
        Self {
            origins: Vec::new(),
            rows: Vec::new(),
            order: SlabOrder::default(),
        }
    }
}

/// The `basis/mls` system.
pub fn mls_basis<D: Dim>(
    grid: Res<Grid<D>>,
    mut stencils: ResMut<MlsStencils<D>>,
    particles: Query<&Position<D>, With<Particle>>,
) {
    let positions = single_table(particles.contiguous_iter(), "particles").unwrap_or(&[]);
    let lattice = Lattice::<D>::of(&grid);
    let MlsStencils {
        origins,
        rows,
        order,
    } = &mut *stencils;
    origins.resize(positions.len(), StencilOrigin::OUTSIDE);
    rows.resize(positions.len(), u32::MAX);
    origins
        .par_chunks_mut(BLOCK_ROWS)
        .zip(rows.par_chunks_mut(BLOCK_ROWS))
        .zip(positions.par_chunks(BLOCK_ROWS))
        .for_each(|((origins, rows), positions)| {
            vectorised(
                #[inline(always)]
                || {
                    for ((origin, row), x) in origins.iter_mut().zip(rows).zip(positions) {
                        (*origin, *row) = match locate(&lattice, x.0) {
                            Some((o, r)) => (o, r as u32),
                            None => (StencilOrigin::OUTSIDE, u32::MAX),
                        };
                    }
                },
            )
        });
    order.sort(rows, lattice.rows().div_ceil(SLAB_ROWS));
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::*;

    /// Particles are ordered by the slab of their stencil's first row, in index order within a
    /// slab.
    #[test]
    fn particles_are_ordered_by_slab() {
        let mut world = tiny_world::<Two>(8, 0.5, 0.1);
        world.insert_resource(MlsStencils::<Two>::default());
        for y in [3.4, 0.1, 1.3, 3.2, 0.6, 1.9] {
            spawn_particle(&mut world, DVec2::new(1.0, y), DVec2::ZERO, 1.0, 0.1);
        }
        run_system(&mut world, mls_basis::<Two>);
        let slabs = world.resource::<MlsStencils<Two>>();
        // Rows ⌊y/h − ½⌋ folded to [0, 6]: 6, 0, 2, 5, 0, 3; slabs of two rows: 3, 0, 1, 2, 0, 1.
        assert_eq!(slabs.rows, vec![6, 0, 2, 5, 0, 3]);
        assert_eq!(slabs.order.order, vec![1, 4, 2, 5, 3, 0]);
        assert_eq!(slabs.order.offsets, vec![0, 2, 4, 5, 6, 6]);
    }
}
