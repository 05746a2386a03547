//! ε-neighbourhoods by the node-linked method (Appendix C of eigensoftening-lme-mpm.md).
//!
//! - Stage: neighbour. Registration name: `neighbour/node_linked`.
//! - Algorithm 3: each particle is linked to its closest grid node `I₀`; each node keeps the
//!   list of particles linked to it; the candidates of `p` are the particles linked to the nodes
//!   near `I₀(p)`, then filtered to the radius ε. "Near" is every node within `ε + √d h` of
//!   `I₀(p)` (d the dimension): a particle is within `√d h/2` of its closest node, so two
//!   particles within ε have closest nodes at most `ε + √d h` apart, and no neighbour is
//!   missed. Rebuilt every step, as in the paper; the lists equal those of
//!   `neighbour/kdtree` (same order, self included), so the two can be swapped to compare cost.

use super::{NeighbourParams, PARAM_DOCS, filter_row, parse_params};
use fractum_engine::dim::lattice_range;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `neighbour/node_linked`.
pub const REGISTRATION: Registration = Registration {
    name: "neighbour/node_linked",
    summary: "ε-neighbourhoods by linking particles to their closest node (paper Appendix C)",
    params: PARAM_DOCS,
    requires: &[],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let graded = installer.world().resource::<Grid<D>>().is_graded();
    if graded {
        // The node links count ε in node spacings of one size.
        return Err(params.error(
            "",
            "neighbour/node_linked needs a uniform grid (this scene's grid has `refine` \
             intervals); use neighbour/kdtree on a graded grid",
        ));
    }
    let parsed = parse_params(params)?;
    let h = installer.world().resource::<Grid<D>>().spacing;
    let cells = parsed.epsilon_cells(h);
    // Linked through nodes, a particle's neighbours lie up to a cell beyond ε.
    super::declare_lists(installer, "neighbour/node_linked", &[cells + 0.5]);
    installer.declare_particle_reach("the ε-neighbourhood and a cell", (cells + 1.0) * h);
    installer.insert_resource(parsed);
    installer.init_resource::<Neighbourhoods>();
    installer.add_systems(node_linked_neighbours::<D>);
    Ok(())
}

/// Lattice coordinates of the node closest to `x`.
pub fn closest_node<D: Dim>(grid: &Grid<D>, x: D::Vector) -> D::Cell {
    let local = ((x - grid.min) / grid.spacing).round();
    let counts = grid.nodes_per_axis();
    D::Cell::from_fn(|a| (local[a].max(0.0) as usize).min(counts[a] - 1))
}

/// Lattice offsets of the nodes within `limit` node spacings of a node, in lattice order.
pub fn near_offsets<D: Dim>(limit: f64) -> Vec<[isize; 3]> {
    let reach = limit.floor() as isize;
    let side = D::Cell::from_fn(|_| 2 * reach as usize + 1);
    lattice_range(D::Cell::default(), side)
        .map(|k| std::array::from_fn(|a| if a < D::N { k[a] as isize - reach } else { 0 }))
        .filter(|d: &[isize; 3]| ((d.iter().map(|c| c * c).sum::<isize>()) as f64).sqrt() <= limit)
        .collect()
}

/// Particle rows linked to each node: CSR offsets by node index and the members, in particle
/// order (a counting sort).
fn link_particles<D: Dim>(grid: &Grid<D>, linked: &[D::Cell]) -> (Vec<usize>, Vec<u32>) {
    let node_count = grid.node_count();
    let mut offsets = vec![0usize; node_count + 1];
    for cell in linked {
        offsets[grid.node_index(*cell) + 1] += 1;
    }
    for k in 0..node_count {
        offsets[k + 1] += offsets[k];
    }
    let mut cursor = offsets.clone();
    let mut members = vec![0u32; linked.len()];
    for (p, cell) in linked.iter().enumerate() {
        let node = grid.node_index(*cell);
        members[cursor[node]] = p as u32;
        cursor[node] += 1;
    }
    (offsets, members)
}

/// The `neighbour/node_linked` system.
pub fn node_linked_neighbours<D: Dim>(
    grid: Res<Grid<D>>,
    params: Res<NeighbourParams>,
    mut neighbourhoods: ResMut<Neighbourhoods>,
    particles: Query<(&Position<D>, &BodyId), With<Particle>>,
) {
    let (positions, bodies) =
        single_table(particles.contiguous_iter(), "particles").unwrap_or((&[], &[]));
    let h = grid.spacing;
    let epsilon = params.epsilon(h);
    let counts = grid.nodes_per_axis();
    let linked: Vec<D::Cell> = positions
        .par_iter()
        .map(|x| closest_node(&grid, x.0))
        .collect();
    let (offsets, members) = link_particles(&grid, &linked);
    let near = near_offsets::<D>((epsilon + (D::N as f64).sqrt() * h) / h);
    neighbourhoods.rebuilds += 1;
    neighbourhoods.fill_rows(positions.len(), epsilon, |p, out| {
        let home = linked[p];
        let candidates = near.iter().filter_map(|d| {
            let mut node = home;
            for a in 0..D::N {
                let c = home[a] as isize + d[a];
                if c < 0 || c as usize >= counts[a] {
                    return None;
                }
                node[a] = c as usize;
            }
            // A rank holds the nodes its particles reach: a node it does not hold links none.
            grid.held_node_index(node)
        });
        // Each particle is linked to one node and each node visited once: no duplicates, but
        // the order is by node.
        let start = out.len();
        for k in candidates {
            let members = &members[offsets[k]..offsets[k + 1]];
            filter_row(
                p,
                members,
                positions,
                bodies,
                epsilon,
                params.same_body,
                out,
            );
        }
        out[start..].sort_unstable();
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<NeighbourParams>(&REGISTRATION);
    }
    use crate::neighbour::kdtree::{KdTreeCandidates, kdtree_neighbours};
    use crate::spatial::Spatial;
    use fractum_engine::testing::*;

    /// Lists from both builders on a scattered cloud of `count` particles in the unit box.
    fn same_lists<D: Spatial>(cells: usize, c_epsilon: f64, count: usize)
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(cells, 1.0 / cells as f64, 1e-3);
        world.insert_resource(NeighbourParams {
            c_epsilon,
            skin: 0.25,
            same_body: false,
            radius: None,
        });
        world.insert_resource(KdTreeCandidates::<D>::default());
        // A scattered cloud: a deterministic pseudo-random sequence.
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..count {
            let x = D::Vector::from_fn(|_| next());
            spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.001);
        }
        world.insert_resource(Neighbourhoods::default());
        run_system(&mut world, node_linked_neighbours::<D>);
        let linked = world.resource::<Neighbourhoods>().clone();
        world.insert_resource(Neighbourhoods::default());
        run_system(&mut world, kdtree_neighbours::<D>);
        let kdtree = world.resource::<Neighbourhoods>().clone();
        assert_eq!(linked.particle_count(), kdtree.particle_count());
        for p in 0..linked.particle_count() {
            assert_eq!(linked.of(p), kdtree.of(p));
        }
        assert!(
            linked.entry_count() > 3 * count,
            "the cloud is dense enough to test something"
        );
    }

    #[test]
    fn node_linked_lists_equal_the_kd_tree_lists() {
        same_lists::<Two>(10, 1.7, 300);
        same_lists::<Three>(6, 1.2, 600);
    }

    #[test]
    fn same_body_keeps_bodies_apart() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        world.insert_resource(NeighbourParams {
            c_epsilon: 1.0,
            skin: 0.0,
            same_body: true,
            radius: None,
        });
        world.insert_resource(Neighbourhoods::default());
        let a = spawn_particle(&mut world, DVec2::new(0.5, 0.5), DVec2::ZERO, 1.0, 0.01);
        spawn_particle(&mut world, DVec2::new(0.6, 0.5), DVec2::ZERO, 1.0, 0.01);
        world.get_mut::<BodyId>(a).unwrap().0 = 1;
        run_system(&mut world, node_linked_neighbours::<Two>);
        let n = world.resource::<Neighbourhoods>().clone();
        assert_eq!(n.of(0), &[0]);
        assert_eq!(n.of(1), &[1]);
    }
}
