//! Uniform quadratic and cubic B-spline shape functions.
//!
//! - Stage: basis. Registration name: `basis/bspline`.
//! - The weight of node `I` at a particle at `x` is the tensor product of the cardinal
//!   B-spline of order `p` (2: quadratic, 3: cubic) centred on the node, `N_I(x) = Π_a
//!   B_p((x_a − x_Ia)/h)` (the B-spline MPM of Steffen, Kirby & Berzins 2008; Stomakhin et al.
//!   2013 for the quadratic one), with, in cell units `ξ`:
//!   - quadratic: `¾ − ξ²` for `|ξ| < ½`, `½ (3/2 − |ξ|)²` for `½ ≤ |ξ| < 3/2`;
//!   - cubic: `½|ξ|³ − ξ² + ⅔` for `|ξ| < 1`, `(2 − |ξ|)³ / 6` for `1 ≤ |ξ| < 2`.
//!
//!   A particle connects to 3 nodes per axis (quadratic; 9 in 2D, 27 in 3D) or 4 (cubic; 16,
//!   64). The transfers are dfg-partitioning-mpm.md's eqs. (1)–(4) and (7) with these `N_Ip`
//!   and `∇N_Ip`, as for every basis.
//! - Why it exists: the weights are C¹ (quadratic) or C² (cubic) in the particle's position,
//!   so a particle crossing a cell face changes its weights and gradients continuously. The
//!   multilinear tents' gradient jumps there (the cell-crossing error), and a struck body then
//!   shows damage where the stress never reached the strength.
//! - Rows are partitions of unity that reproduce linear fields (`Σ N = 1`, `Σ N x_I = x_p`,
//!   `Σ ∇N = 0`, `Σ x_I ⊗ ∇N_I = I`): the cardinal splines on a uniform lattice do.
//! - The grid's edges: the splines are the uniform ones everywhere, none modified at the
//!   boundary. The grid's outer cells are the ghost layer: every particle must stay ½ cell
//!   (quadratic) or 1 cell (cubic) inside the grid, `(order − 1)/2`, so that every node its
//!   support reaches exists; a particle whose support would leave the grid stops the run with a
//!   message naming it. A body resting on a held boundary therefore needs the grid extended
//!   past that boundary. A graded grid is refused (the splines here need one spacing).
//! - Weights and gradients are computed once per particle per step into the connectivity
//!   tables, which every transfer of the step reads.

use super::tensor::{AxisFactors, axis_factors, write_tensor_row};
use fractum_engine::health::{Blowup, Health, fmt_vector};
use fractum_engine::prelude::*;
use serde::Deserialize;

/// Registration of `basis/bspline`.
pub const REGISTRATION: Registration = Registration {
    name: "basis/bspline",
    summary: "uniform quadratic or cubic B-splines: C¹/C² weights, no cell-crossing error (up \
              to 9 or 16 nodes per particle in 2D, 27 or 64 in 3D)",
    params: &[ParamDoc {
        name: "order",
        ty: "u32",
        default: Some("2"),
        doc: "2 (quadratic, 3 nodes per axis) or 3 (cubic, 4 nodes per axis); particles must \
              stay (order - 1)/2 cells inside the grid",
    }],
    requires: &[],
    install: generic_install!(install),
};

/// Parameters of `basis/bspline`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct BsplineParams {
    /// Polynomial order of the splines: 2 (quadratic) or 3 (cubic).
    pub order: u32,
}

impl Default for BsplineParams {
    fn default() -> Self {
        Self { order: 2 }
    }
}

impl BsplineParams {
    /// How far the support reaches from a node, in cells: `(order + 1) / 2`.
    pub fn reach(&self) -> f64 {
        f64::from(self.order + 1) / 2.0
    }

    /// The spline's name in messages.
    pub fn name(&self) -> &'static str {
        if self.order == 3 {
            "cubic"
        } else {
            "quadratic"
        }
    }
}

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    let parsed: BsplineParams = params.parse()?;
    params.require(
        "order",
        matches!(parsed.order, 2 | 3),
        "expected 2 (quadratic) or 3 (cubic)",
    )?;
    if installer.world().resource::<Grid<D>>().is_graded() {
        return Err(params.error(
            "",
            "basis/bspline needs a uniform grid (this scene's grid has `refine` intervals): \
             its splines are the cardinal ones of one spacing; use basis/linear or basis/lme \
             on a graded grid",
        ));
    }
    let nodes = f64::from(parsed.order + 1).powi(installer.dimension().count() as i32);
    super::declare_support::<D>(
        installer,
        "basis/bspline",
        (nodes, parsed.reach()),
        true,
        0.0,
    );
    installer.insert_resource(parsed);
    installer.add_systems(bspline_basis::<D>);
    Ok(())
}

/// The quadratic B-spline and its slope at `ξ` cells from its node.
pub fn quadratic(xi: f64) -> (f64, f64) {
    let distance = xi.abs();
    if distance < 0.5 {
        (0.75 - xi * xi, -2.0 * xi)
    } else if distance < 1.5 {
        let reach = 1.5 - distance;
        (0.5 * reach * reach, -xi.signum() * reach)
    } else {
        (0.0, 0.0)
    }
}

/// The cubic B-spline and its slope at `ξ` cells from its node.
pub fn cubic(xi: f64) -> (f64, f64) {
    let distance = xi.abs();
    if distance < 1.0 {
        (
            0.5 * distance * distance * distance - xi * xi + 2.0 / 3.0,
            1.5 * xi * distance - 2.0 * xi,
        )
    } else if distance < 2.0 {
        let reach = 2.0 - distance;
        (
            reach * reach * reach / 6.0,
            -xi.signum() * 0.5 * reach * reach,
        )
    } else {
        (0.0, 0.0)
    }
}

/// One axis of the weight: `(N, dN/dr)` at signed distance `r` from the node, spacing `h`.
pub fn spline_1d(order: u32, r: f64, h: f64) -> (f64, f64) {
    let (value, slope) = if order == 3 {
        cubic(r / h)
    } else {
        quadratic(r / h)
    };
    (value, slope / h)
}

/// The per-axis factors of the row of a particle at `x`, or the first axis along which its
/// support leaves the grid.
pub fn spline_axes<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    params: &BsplineParams,
) -> Result<AxisFactors, usize> {
    let h = grid.spacing;
    axis_factors(grid, x, params.reach(), |r| spline_1d(params.order, r, h))
}

/// The `basis/bspline` system: rebuilds the connectivity for the current positions.
pub fn bspline_basis<D: Dim>(
    clock: Res<SimClock>,
    grid: Res<Grid<D>>,
    params: Res<BsplineParams>,
    mut health: ResMut<Health>,
    mut connectivity: ResMut<Connectivity<D>>,
    particles: Query<(&ParticleId, &Position<D>), With<Particle>>,
) {
    let (ids, positions) =
        single_table(particles.contiguous_iter(), "particles").unwrap_or((&[], &[]));
    let (grid, params) = (&*grid, &*params);
    // The rows go straight into the connectivity tables (a failed particle gets none).
    let results: Vec<Result<(), usize>> = connectivity.fill_rows(
        positions.len(),
        grid.node_count(),
        |p| spline_axes(grid, positions[p].0, params).map_or(0, |a| a.width(D::N)),
        || (),
        |_, p, nodes, weights, gradients| {
            let axes = spline_axes(grid, positions[p].0, params)?;
            write_tensor_row(grid, &axes, (nodes, weights, gradients));
            Ok(())
        },
    );
    if let Some((p, Err(axis))) = results.iter().enumerate().find(|(_, r)| r.is_err()) {
        health.fail(Blowup::new(
            clock.step + 1,
            Stage::Basis,
            format!(
                "particle {} at {}: its {} B-spline support reaches past the grid along axis \
                 {axis}; the grid's outer cells are the splines' ghost layer, so particles must \
                 stay {} cell(s) inside it: extend the grid",
                ids[p].0,
                fmt_vector(positions[p].0, D::N),
                params.name(),
                params.reach() - 1.0
            ),
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tensor::assert_consistent_row;
    use crate::basis::tensor::tensor_row;
    use fractum_engine::testing::*;

    /// `fractum systems` documents the fields its parameters read, and its documented defaults
    /// are theirs.
    #[test]
    fn parameter_docs_match_the_parameters() {
        fractum_engine::testing::assert_defaults::<BsplineParams>(&REGISTRATION);
    }

    /// Partition of unity, linear reproduction, Σ∇N = 0 and Σ x_I ⊗ ∇N_I = I for a row.
    fn check_consistency<D: Dim>(grid: &Grid<D>, x: D::Vector, order: u32, nodes: usize) {
        let params = BsplineParams { order };
        let row = tensor_row(grid, &spline_axes(grid, x, &params).unwrap());
        assert_eq!(row.len(), nodes, "{row:?}");
        assert_consistent_row(grid, x, &row, 1e-13);
    }

    #[test]
    fn rows_are_partitions_of_unity_that_reproduce_linear_fields() {
        let grid = Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [8, 8],
            graded: None,
            window: None,
        };
        for x in [
            DVec2::new(0.3, 3.3),
            DVec2::new(0.01, 3.99),
            DVec2::new(0.74, 3.26),
        ] {
            check_consistency(&grid, x, 2, 9);
            check_consistency(&grid, x, 3, 16);
        }
        let grid = Grid::<Three> {
            min: DVec3::new(-1.0, 2.0, 0.5),
            spacing: 0.5,
            cells: [8, 8, 8],
            graded: None,
            window: None,
        };
        check_consistency(&grid, DVec3::new(0.3, 3.3, 2.1), 2, 27);
        check_consistency(&grid, DVec3::new(0.3, 3.3, 2.1), 3, 64);
    }

    /// The weights and slopes are continuous where the tents' slopes jump: at every breakpoint
    /// of each spline, and so wherever a particle crosses a cell face.
    #[test]
    fn weights_and_slopes_are_continuous_across_every_breakpoint() {
        let close =
            |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-8 && (a.1 - b.1).abs() < 1e-8;
        for edge in [-1.5, -0.5, 0.5, 1.5] {
            assert!(
                close(quadratic(edge - 1e-9), quadratic(edge + 1e-9)),
                "{edge}"
            );
        }
        for edge in [-2.0, -1.0, 0.0, 1.0, 2.0] {
            assert!(close(cubic(edge - 1e-9), cubic(edge + 1e-9)), "{edge}");
        }
        // A row's gradient across a cell face: no jump, where the tents' jumps by 1/h.
        let grid = Grid::<Two> {
            min: DVec2::ZERO,
            spacing: 1.0,
            cells: [8, 8],
            graded: None,
            window: None,
        };
        let params = BsplineParams::default();
        let gradient_at = |x: f64| {
            let row = tensor_row(
                &grid,
                &spline_axes(&grid, DVec2::new(x, 4.3), &params).unwrap(),
            );
            let node = grid.node_index([4, 4]) as u32;
            row.iter()
                .find(|e| e.0 == node)
                .map_or(DVec2::ZERO, |e| e.2)
        };
        assert!((gradient_at(4.0 - 1e-9) - gradient_at(4.0 + 1e-9)).length() < 1e-8);
    }

    /// The system alone on a tiny world, in both dimensions: each particle's row sums to one,
    /// and a particle whose support would reach past the grid stops the run at the basis stage.
    fn the_system_builds_rows_and_reports_a_support_outside_the_grid<D: Dim>()
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(8, 0.25, 1e-3);
        world.insert_resource(BsplineParams::default());
        let inside = spawn_particle(
            &mut world,
            D::Vector::splat(1.1),
            D::Vector::ZERO,
            1.0,
            0.015625,
        );
        run_system(&mut world, bspline_basis::<D>);
        let connectivity = world.resource::<Connectivity<D>>();
        assert_eq!(connectivity.row(0).len(), 3usize.pow(D::N as u32));
        let sum: f64 = connectivity.weights[connectivity.row(0)].iter().sum();
        assert!((sum - 1.0).abs() < 1e-14);
        assert!(world.resource::<Health>().failure.is_none());
        // Within half a cell of the grid's edge along the last axis, the spline of the node a
        // cell beyond the edge is not zero there.
        let mut edge = D::Vector::splat(1.1);
        edge[D::N - 1] = 0.1;
        world.get_mut::<Position<D>>(inside).unwrap().0 = edge;
        run_system(&mut world, bspline_basis::<D>);
        let failure = world.resource::<Health>().failure.clone().unwrap();
        assert_eq!(failure.stage, Stage::Basis);
        assert!(
            failure.message.contains(&format!("axis {}", D::N - 1))
                && failure.message.contains("quadratic B-spline"),
            "{}",
            failure.message
        );
    }

    #[test]
    fn the_system_builds_rows_and_reports_a_support_outside_the_grid_in_2d() {
        the_system_builds_rows_and_reports_a_support_outside_the_grid::<Two>();
    }

    #[test]
    fn the_system_builds_rows_and_reports_a_support_outside_the_grid_in_3d() {
        the_system_builds_rows_and_reports_a_support_outside_the_grid::<Three>();
    }
}
