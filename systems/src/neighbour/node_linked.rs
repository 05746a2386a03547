//! ε-neighbourhoods by the node-linked method (Appendix C of eigensoftening-lme-mpm.md).
//!
//! - Stage: neighbour. Registration name: `neighbour/node_linked`.
//! - Algorithm 3: each particle is linked to its closest grid node `I₀`; each node keeps the
//!   list of particles linked to it; the candidates of `p` are the particles linked to the nodes
//!   near `I₀(p)`, then filtered to the radius ε. "Near" is every node within `ε + √2 h` of
//!   `I₀(p)`: two particles within ε have closest nodes at most `ε + √2 h` apart, so no
//!   neighbour is missed. Rebuilt every step, as in the paper; the lists equal those of
//!   `neighbour/kdtree` (same order, self included), so the two can be swapped to compare cost.

use super::{NeighbourParams, PARAM_DOCS, filter_row, parse_params};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `neighbour/node_linked`.
pub const REGISTRATION: Registration = Registration {
    name: "neighbour/node_linked",
    summary: "ε-neighbourhoods by linking particles to their closest node (paper Appendix C)",
    params: PARAM_DOCS,
    requires: &[],
    install,
};

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    installer.insert_resource(parse_params(params)?);
    installer.init_resource::<Neighbourhoods>();
    installer.add_systems(node_linked_neighbours);
    Ok(())
}

/// Closest node `(i, j)` of `x`.
pub fn closest_node(grid: &Grid, x: Vector) -> [usize; 2] {
    let local = ((x - grid.min) / grid.spacing).round();
    let [nx, ny] = grid.nodes_per_axis();
    [
        (local.x.max(0.0) as usize).min(nx - 1),
        (local.y.max(0.0) as usize).min(ny - 1),
    ]
}

/// The `neighbour/node_linked` system.
pub fn node_linked_neighbours(
    grid: Res<Grid>,
    params: Res<NeighbourParams>,
    mut neighbourhoods: ResMut<Neighbourhoods>,
    particles: Query<(&Position, &BodyId), With<Particle>>,
) {
    let (positions, bodies) =
        single_table(particles.contiguous_iter(), "particles").unwrap_or((&[], &[]));
    let h = grid.spacing;
    let epsilon = params.c_epsilon * h;
    let [nx, ny] = grid.nodes_per_axis();
    // Particles linked to each node (CSR by counting sort, particle order kept).
    let linked: Vec<[usize; 2]> = positions
        .par_iter()
        .map(|x| closest_node(&grid, x.0))
        .collect();
    let mut offsets = vec![0usize; nx * ny + 1];
    for [i, j] in &linked {
        offsets[i + j * nx + 1] += 1;
    }
    for k in 0..nx * ny {
        offsets[k + 1] += offsets[k];
    }
    let mut cursor = offsets.clone();
    let mut members = vec![0u32; positions.len()];
    for (p, [i, j]) in linked.iter().enumerate() {
        members[cursor[i + j * nx]] = p as u32;
        cursor[i + j * nx] += 1;
    }
    // Node offsets within ε + √2 h.
    let reach = ((epsilon + 2f64.sqrt() * h) / h).floor() as isize;
    let limit = (epsilon + 2f64.sqrt() * h) / h;
    let near: Vec<(isize, isize)> = (-reach..=reach)
        .flat_map(|dj| (-reach..=reach).map(move |di| (di, dj)))
        .filter(|(di, dj)| ((di * di + dj * dj) as f64).sqrt() <= limit)
        .collect();
    let rows: Vec<Vec<u32>> = (0..positions.len())
        .into_par_iter()
        .map(|p| {
            let [i, j] = linked[p];
            let candidates = near.iter().filter_map(|(di, dj)| {
                let (a, b) = (i as isize + di, j as isize + dj);
                (a >= 0 && b >= 0 && (a as usize) < nx && (b as usize) < ny)
                    .then(|| a as usize + b as usize * nx)
            });
            let candidates =
                candidates.flat_map(|k| members[offsets[k]..offsets[k + 1]].iter().copied());
            filter_row(p, candidates, positions, bodies, epsilon, params.same_body)
        })
        .collect();
    neighbourhoods.rebuilds += 1;
    neighbourhoods.set_rows(&rows, epsilon);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::neighbour::kdtree::{KdTreeCandidates, kdtree_neighbours};
    use fractum_engine::testing::*;

    #[test]
    fn node_linked_lists_equal_the_kd_tree_lists() {
        let mut world = tiny_world(10, 0.1, 1e-3);
        world.insert_resource(NeighbourParams {
            c_epsilon: 1.7,
            skin: 0.25,
            same_body: false,
        });
        world.insert_resource(KdTreeCandidates::default());
        // A scattered cloud: a deterministic pseudo-random sequence.
        let mut seed = 12345u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..300 {
            let x = Vector::new(next(), next());
            spawn_particle(&mut world, x, Vector::ZERO, 1.0, 0.001);
        }
        world.insert_resource(Neighbourhoods::default());
        run_system(&mut world, node_linked_neighbours);
        let linked = world.resource::<Neighbourhoods>().clone();
        world.insert_resource(Neighbourhoods::default());
        run_system(&mut world, kdtree_neighbours);
        let kdtree = world.resource::<Neighbourhoods>().clone();
        assert_eq!(linked.offsets, kdtree.offsets);
        assert_eq!(linked.list, kdtree.list);
        assert!(
            linked.list.len() > 3 * 300,
            "the cloud is dense enough to test something"
        );
    }

    #[test]
    fn same_body_keeps_bodies_apart() {
        let mut world = tiny_world(4, 0.25, 1e-3);
        world.insert_resource(NeighbourParams {
            c_epsilon: 1.0,
            skin: 0.0,
            same_body: true,
        });
        world.insert_resource(Neighbourhoods::default());
        let a = spawn_particle(&mut world, Vector::new(0.5, 0.5), Vector::ZERO, 1.0, 0.01);
        spawn_particle(&mut world, Vector::new(0.6, 0.5), Vector::ZERO, 1.0, 0.01);
        world.get_mut::<BodyId>(a).unwrap().0 = 1;
        run_system(&mut world, node_linked_neighbours);
        let n = world.resource::<Neighbourhoods>().clone();
        assert_eq!(n.of(0), &[0]);
        assert_eq!(n.of(1), &[1]);
    }
}
