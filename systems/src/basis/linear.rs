//! Bilinear tent shape functions on the uniform background grid.
//!
//! - Stage: basis. Registration name: `basis/linear`.
//! - Each particle is connected to the four nodes of the cell that contains it, with
//!   `N_I(x) = (1 − |x − x_I|/h)(1 − |y − y_I|/h)` and its gradient (the standard MPM basis of
//!   Sulsky et al.; the "Dirac delta" integration of eq. (1)–(4) in Homel & Herbold,
//!   dfg-partitioning-mpm.md §1.1).
//! - Writes the [`Connectivity`] tables that every transfer reads.

use fractum_engine::prelude::*;

/// Registration of `basis/linear`.
pub const REGISTRATION: Registration = Registration {
    name: "basis/linear",
    summary: "bilinear tent functions on the uniform grid (4 nodes per particle)",
    params: &[],
    requires: &[],
    install,
};

fn install(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    installer.add_systems(linear_basis);
    Ok(())
}

/// Shape functions of the four nodes of the cell holding `x`: `(node, N, ∇N)`.
///
/// Returns `None` when `x` lies outside the grid.
pub fn bilinear_row(grid: &Grid, x: Vector) -> Option<[(u32, f64, Vector); 4]> {
    let [i, j] = grid.cell_of(x)?;
    let h = grid.spacing;
    let corner = grid.min + Vector::new(i as f64, j as f64) * h;
    let xi = ((x - corner) / h).clamp(Vector::ZERO, Vector::ONE);
    let (sx, sy) = (xi.x, xi.y);
    let node = |di: usize, dj: usize| grid.node_index(i + di, j + dj) as u32;
    Some([
        (
            node(0, 0),
            (1.0 - sx) * (1.0 - sy),
            Vector::new(-(1.0 - sy), -(1.0 - sx)) / h,
        ),
        (node(1, 0), sx * (1.0 - sy), Vector::new(1.0 - sy, -sx) / h),
        (node(0, 1), (1.0 - sx) * sy, Vector::new(-sy, 1.0 - sx) / h),
        (node(1, 1), sx * sy, Vector::new(sy, sx) / h),
    ])
}

/// The `basis/linear` system: rebuilds the connectivity for the current positions.
pub fn linear_basis(
    grid: Res<Grid>,
    mut connectivity: ResMut<Connectivity>,
    particles: Query<&Position, With<Particle>>,
) {
    let positions = single_table(particles.contiguous_iter(), "particles").unwrap_or(&[]);
    let grid = *grid;
    connectivity.fill_fixed_width(
        positions.len(),
        4,
        grid.node_count(),
        |p, nodes, weights, gradients| {
            // A particle outside the grid gets no support; the engine's health check stops the run
            // before such a state is stepped.
            let row = bilinear_row(&grid, positions[p].0).unwrap_or([(0, 0.0, Vector::ZERO); 4]);
            for (k, (node, weight, gradient)) in row.into_iter().enumerate() {
                nodes[k] = node;
                weights[k] = weight;
                gradients[k] = gradient;
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use fractum_engine::testing::*;

    #[test]
    fn row_is_a_partition_of_unity_that_reproduces_linear_fields() {
        let grid = Grid {
            min: Vector::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [4, 4],
        };
        for x in [
            Vector::new(-0.8, 2.1),
            Vector::new(0.24, 3.49),
            Vector::new(1.0, 4.0),
        ] {
            let row = bilinear_row(&grid, x).unwrap();
            let sum: f64 = row.iter().map(|e| e.1).sum();
            let first: Vector = row
                .iter()
                .map(|e| e.1 * grid.node_position(e.0 as usize))
                .sum();
            let grad_sum: Vector = row.iter().map(|e| e.2).sum();
            // Σ x_I ⊗ ∇N_I = identity.
            let jacobian: Matrix = row
                .iter()
                .map(|e| fractum_engine::dim::outer(grid.node_position(e.0 as usize), e.2))
                .fold(Matrix::ZERO, |a, b| a + b);
            assert!((sum - 1.0).abs() < 1e-14);
            assert!((first - x).length() < 1e-14);
            assert!(grad_sum.length() < 1e-12);
            assert!(
                (jacobian - Matrix::IDENTITY)
                    .abs()
                    .to_cols_array()
                    .iter()
                    .all(|v| *v < 1e-12)
            );
        }
        assert!(bilinear_row(&grid, Vector::new(1.1, 3.0)).is_none());
    }

    #[test]
    fn system_connects_each_particle_to_its_cell_nodes() {
        let mut world = tiny_world(2, 0.5, 1e-3);
        spawn_particle(&mut world, Vector::new(0.25, 0.25), Vector::ZERO, 1.0, 0.1);
        spawn_particle(&mut world, Vector::new(0.75, 0.5), Vector::ZERO, 1.0, 0.1);
        run_system(&mut world, linear_basis);
        let c = world.resource::<Connectivity>();
        assert_eq!(c.particle_count(), 2);
        assert_eq!(&c.nodes[0..4], &[0, 1, 3, 4]);
        assert_eq!(&c.weights[0..4], &[0.25; 4]);
        // Second particle sits on the edge between cell rows: the upper cell (row 1) holds it.
        assert_eq!(&c.nodes[4..8], &[4, 5, 7, 8]);
        assert_eq!(&c.weights[4..8], &[0.5, 0.5, 0.0, 0.0]);
        // Node 4 (the centre) is touched by both particles, in particle order.
        let slots = &c.node_entries[c.node_offsets[4]..c.node_offsets[5]];
        assert_eq!(slots.iter().map(|s| s.1).collect::<Vec<_>>(), vec![0, 1]);
    }
}
