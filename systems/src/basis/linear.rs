//! Multilinear tent shape functions on the background grid: bilinear in 2D, trilinear in 3D,
//! on uniform and on graded (rectilinear) cells.
//!
//! - Stage: basis. Registration name: `basis/linear`.
//! - Each particle is connected to the 2^d nodes of the cell that contains it, with
//!   `N_I(x) = Π_a (1 − |x_a − x_I,a|/h_a)` and its gradient, `h_a` the cell's width along
//!   axis `a` (the standard MPM basis of Sulsky et
//!   al.; the "Dirac delta" integration of eqs. (1)–(4) in Homel & Herbold,
//!   dfg-partitioning-mpm.md §1.1).
//! - Writes the [`Connectivity`] tables that every transfer reads.

use fractum_engine::prelude::*;

/// Registration of `basis/linear`.
pub const REGISTRATION: Registration = Registration {
    name: "basis/linear",
    summary: "multilinear tent functions on the uniform grid (4 nodes per particle in 2D, 8 in 3D)",
    params: &[],
    requires: &[],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    let nodes = (1 << installer.dimension().count()) as f64;
    super::declare_support::<D>(installer, "basis/linear", (nodes, 1.0), true, 0.0);
    installer.add_systems(linear_basis::<D>);
    Ok(())
}

/// Number of nodes each particle connects to: `2^d`.
pub fn nodes_per_particle<D: Dim>() -> usize {
    1 << D::N
}

/// Writes the shape functions of the `2^d` nodes of the cell holding `x` into the row slices
/// (node, `N`, `∇N`), nodes in lattice order (first axis fastest). Returns `false`, with the
/// row zeroed, when `x` lies outside the grid.
pub fn fill_multilinear_row<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    nodes: &mut [u32],
    weights: &mut [f64],
    gradients: &mut [D::Vector],
) -> bool {
    let Some(cell) = grid.cell_of(x) else {
        nodes.fill(0);
        weights.fill(0.0);
        gradients.fill(D::Vector::ZERO);
        return false;
    };
    // The cell's lower corner and its widths (all h on a uniform grid).
    let (corner, width) = if grid.is_graded() {
        (
            grid.lattice_position(cell),
            D::Vector::from_fn(|a| grid.cell_width(a, cell[a])),
        )
    } else {
        let h = grid.spacing;
        (
            grid.min + D::Vector::from_fn(|a| cell[a] as f64) * h,
            D::Vector::splat(h),
        )
    };
    let xi = ((x - corner) / width).clamp(D::Vector::ZERO, D::Vector::ONE);
    for k in 0..nodes_per_particle::<D>() {
        // Bit a of k says whether the node is at the upper end of the cell along axis a.
        let upper = |a: usize| (k >> a) & 1 == 1;
        let factor = |a: usize| if upper(a) { xi[a] } else { 1.0 - xi[a] };
        nodes[k] = grid.node_index(D::Cell::from_fn(|a| cell[a] + usize::from(upper(a)))) as u32;
        weights[k] = (0..D::N).fold(1.0, |n, a| n * factor(a));
        gradients[k] = D::Vector::from_fn(|a| {
            let slope = if upper(a) { 1.0 } else { -1.0 };
            let across = (0..D::N)
                .filter(|b| *b != a)
                .fold(1.0, |n, b| n * factor(b));
            slope * across / width[a]
        });
    }
    true
}

/// The row of `x` as `(node, N, ∇N)` entries, or `None` outside the grid (an allocating
/// convenience over [`fill_multilinear_row`]).
pub fn multilinear_row<D: Dim>(grid: &Grid<D>, x: D::Vector) -> Option<Vec<(u32, f64, D::Vector)>> {
    let width = nodes_per_particle::<D>();
    let (mut nodes, mut weights, mut gradients) = (
        vec![0; width],
        vec![0.0; width],
        vec![D::Vector::ZERO; width],
    );
    fill_multilinear_row(grid, x, &mut nodes, &mut weights, &mut gradients).then(|| {
        (0..width)
            .map(|k| (nodes[k], weights[k], gradients[k]))
            .collect()
    })
}

/// The `basis/linear` system: rebuilds the connectivity for the current positions.
pub fn linear_basis<D: Dim>(
    grid: Res<Grid<D>>,
    mut connectivity: ResMut<Connectivity<D>>,
    particles: Query<&Position<D>, With<Particle>>,
) {
    let positions = single_table(particles.contiguous_iter(), "particles").unwrap_or(&[]);
    let grid = &*grid;
    connectivity.fill_fixed_width(
        positions.len(),
        nodes_per_particle::<D>(),
        grid.node_count(),
        |p, nodes, weights, gradients| {
            // A particle outside the grid gets no support; the engine's health check stops the
            // run before such a state is stepped.
            fill_multilinear_row(grid, positions[p].0, nodes, weights, gradients);
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::*;

    /// Partition of unity, linear reproduction, Σ∇N = 0 and Σ x_I ⊗ ∇N_I = I at `x`.
    fn check_consistency<D: Dim>(grid: &Grid<D>, x: D::Vector) {
        let row = multilinear_row(grid, x).unwrap();
        crate::basis::tensor::assert_consistent_row(grid, x, &row, 1e-14);
    }

    #[test]
    fn rows_are_a_partition_of_unity_that_reproduces_linear_fields() {
        let grid = Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [4, 4],
            graded: None,
            window: None,
        };
        for x in [
            DVec2::new(-0.8, 2.1),
            DVec2::new(0.24, 3.49),
            DVec2::new(1.0, 4.0),
        ] {
            check_consistency(&grid, x);
        }
        assert!(multilinear_row(&grid, DVec2::new(1.1, 3.0)).is_none());
        let grid = Grid::<Three> {
            min: DVec3::new(-1.0, 2.0, 0.5),
            spacing: 0.5,
            cells: [4, 4, 2],
            graded: None,
            window: None,
        };
        for x in [
            DVec3::new(-0.8, 2.1, 0.6),
            DVec3::new(0.24, 3.49, 1.3),
            DVec3::new(1.0, 4.0, 1.5),
        ] {
            check_consistency(&grid, x);
        }
        assert!(multilinear_row(&grid, DVec3::new(0.0, 3.0, 1.6)).is_none());
    }

    #[test]
    fn rows_on_graded_cells_keep_every_consistency_condition() {
        // Widths 1, 0.25, 0.0625 (16:1 from end to end) along x; 0.5 and 0.125 along y.
        let grid = Grid::<Two>::graded(vec![
            vec![0.0, 1.0, 1.25, 1.3125, 1.375],
            vec![0.0, 0.5, 0.625, 0.75],
        ])
        .unwrap();
        for x in [
            DVec2::new(0.3, 0.1),
            DVec2::new(1.1, 0.55),
            DVec2::new(1.3, 0.7),
            DVec2::new(1.375, 0.75),
        ] {
            check_consistency(&grid, x);
        }
        let grid = Grid::<Three>::graded(vec![
            vec![0.0, 1.0, 1.25],
            vec![0.0, 0.1, 0.5],
            vec![-1.0, 0.0, 0.03125],
        ])
        .unwrap();
        for x in [DVec3::new(1.2, 0.05, 0.01), DVec3::new(0.5, 0.4, -0.5)] {
            check_consistency(&grid, x);
        }
        assert!(multilinear_row(&grid, DVec3::new(1.3, 0.05, 0.01)).is_none());
    }

    #[test]
    fn system_connects_each_particle_to_its_cell_nodes() {
        let mut world = tiny_world::<Two>(2, 0.5, 1e-3);
        spawn_particle(&mut world, DVec2::new(0.25, 0.25), DVec2::ZERO, 1.0, 0.1);
        spawn_particle(&mut world, DVec2::new(0.75, 0.5), DVec2::ZERO, 1.0, 0.1);
        run_system(&mut world, linear_basis::<Two>);
        let c = world.resource::<Connectivity<Two>>();
        assert_eq!(c.particle_count(), 2);
        assert_eq!(&c.nodes[0..4], &[0, 1, 3, 4]);
        assert_eq!(&c.weights[0..4], &[0.25; 4]);
        // Second particle sits on the edge between cell rows: the upper cell (row 1) holds it.
        assert_eq!(&c.nodes[4..8], &[4, 5, 7, 8]);
        assert_eq!(&c.weights[4..8], &[0.5, 0.5, 0.0, 0.0]);
        // Node 4 (the centre) is touched by both particles, in particle order.
        let slots = c.entries_of_node(4);
        assert_eq!(slots.iter().map(|s| s.1).collect::<Vec<_>>(), vec![0, 1]);
    }

    #[test]
    fn system_connects_each_particle_to_the_eight_nodes_of_its_cell_in_3d() {
        let mut world = tiny_world::<Three>(2, 0.5, 1e-3);
        spawn_particle(&mut world, DVec3::splat(0.25), DVec3::ZERO, 1.0, 0.1);
        run_system(&mut world, linear_basis::<Three>);
        let c = world.resource::<Connectivity<Three>>();
        // Nodes (i, j, k) ∈ {0, 1}³ of a 3 × 3 × 3 node lattice: i + 3 j + 9 k.
        assert_eq!(&c.nodes[..], &[0, 1, 3, 4, 9, 10, 12, 13]);
        assert_eq!(&c.weights[..], &[0.125; 8]);
        assert_eq!(c.gradients[0], DVec3::splat(-0.5));
    }
}
