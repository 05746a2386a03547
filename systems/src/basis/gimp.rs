//! Uniform GIMP shape functions: the multilinear tent averaged over each particle's domain.
//!
//! - Stage: basis. Registration name: `basis/gimp`.
//! - Implements the generalized interpolation material point method (Bardenhagen & Kober 2004)
//!   that dfg-partitioning-mpm.md §1.1 writes its transfers with: eqs. (1)–(4) and (7) use the
//!   averages `S̄_Ip` and `∇S̄_Ip` of the grid shape function over the particle domain. The
//!   domain is the particle's undeformed square (cube) of side `l_p = (V_p⁰ / t)^(1/d)`, with
//!   `t` the 2D thickness ("uniform GIMP"; the paper's CPDI deforms it with `F`). Along one
//!   axis, with `r` the distance from the node, `h` the spacing and `l = l_p/2 ≤ h/2`:
//!   - `|r| < l`: `S = 1 − (r² + l²)/(2hl)`, `S' = −r/(hl)`;
//!   - `l ≤ |r| < h − l`: `S = 1 − |r|/h`, `S' = −sign(r)/h`;
//!   - `h − l ≤ |r| < h + l`: `S = (h + l − |r|)²/(4hl)`, `S' = −sign(r)(h + l − |r|)/(2hl)`;
//!
//!   and the d-dimensional weight is the product over the axes. A particle connects to the
//!   nodes where the weight is positive: up to 3 per axis (9 in 2D, 27 in 3D).
//! - Why it exists beside `basis/linear`: at the edge of the support the weight vanishes as
//!   the square of the distance and its gradient linearly, so a node that a particle is just
//!   entering gets a mass and a force that vanish together, and the update-stress-last velocity
//!   gradient `Σ v̄_I ⊗ ∇S̄_I` stays bounded. With the tent functions the force keeps its full
//!   `∇N` while the mass goes to zero, and a loaded particle entering an empty cell drives that
//!   node's `v̄ = (p + Δt f)/m` without bound (the cell-crossing instability; see
//!   `predictor/usl`).
//! - Rows are partitions of unity that reproduce linear fields (`Σ S̄ = 1`, `Σ S̄ x_I = x_p`,
//!   `Σ ∇S̄ = 0`, `Σ x_I ⊗ ∇S̄_I = I`). A particle whose support would reach past the grid stops
//!   the run with a message naming it.

use super::tensor::{
    AxisFactors, AxisRun, Row, axis_factors, axis_runs, runs_width, tensor_row, write_box_row,
    write_tensor_row,
};
use fractum_engine::health::{Blowup, Health, fmt_vector};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Registration of `basis/gimp`.
pub const REGISTRATION: Registration = Registration {
    name: "basis/gimp",
    summary: "uniform GIMP: tent functions averaged over each particle's undeformed domain \
              (up to 9 nodes per particle in 2D, 27 in 3D)",
    params: &[],
    requires: &[],
    install: generic_install!(install),
};

fn install<D: Dim>(installer: &mut Installer, params: &Params) -> Result<(), SceneError> {
    crate::no_params(params)?;
    let graded = installer.world().resource::<Grid<D>>().is_graded();
    if graded {
        // The particle domain's overlap with a tent of two different widths is another
        // integral; uGIMP here assumes one spacing.
        return Err(params.error(
            "",
            "basis/gimp needs a uniform grid (this scene's grid has `refine` intervals); use \
             basis/linear or basis/lme on a graded grid",
        ));
    }
    let nodes = 3f64.powi(installer.dimension().count() as i32);
    // A particle half a cell wide reaches one and a half cells from its centre.
    super::declare_support::<D>(installer, "basis/gimp", (nodes, 1.5), true, 0.0);
    installer.add_systems(gimp_basis::<D>);
    Ok(())
}

/// One axis of the GIMP weight: `(S, dS/dr)` at signed distance `r` from the node, for
/// spacing `h` and particle half-width `l` (0 < l ≤ h/2).
pub fn gimp_1d(r: f64, h: f64, l: f64) -> (f64, f64) {
    let distance = r.abs();
    let sign = r.signum();
    if distance < l {
        (1.0 - (r * r + l * l) / (2.0 * h * l), -r / (h * l))
    } else if distance < h - l {
        (1.0 - distance / h, -sign / h)
    } else if distance < h + l {
        let reach = h + l - distance;
        (reach * reach / (4.0 * h * l), -sign * reach / (2.0 * h * l))
    } else {
        (0.0, 0.0)
    }
}

/// Half the side of a particle's undeformed domain, `l_p / 2`, capped at `h/2` (a particle
/// larger than a cell is treated as one cell wide).
pub fn half_width(initial_volume: f64, thickness: f64, dimensions: usize, h: f64) -> f64 {
    super::domain_half_width(initial_volume, thickness, dimensions).min(0.5 * h)
}

/// The GIMP row of a particle at `x` with half-width `l` (an allocating convenience over
/// [`gimp_axes`] and [`write_tensor_row`]).
pub fn gimp_row<D: Dim>(grid: &Grid<D>, x: D::Vector, l: f64) -> Result<Row<D>, usize> {
    Ok(tensor_row(grid, &gimp_axes(grid, x, l)?))
}

/// The per-axis factors of the GIMP row of a particle at `x` with half-width `l`, or the first
/// axis along which the support leaves the grid: two or three nodes per axis.
pub fn gimp_axes<D: Dim>(grid: &Grid<D>, x: D::Vector, l: f64) -> Result<AxisFactors, usize> {
    let h = grid.spacing;
    axis_factors(grid, x, 1.0 + l / h, |r| gimp_1d(r, h, l))
}

/// [`gimp_axes`] as runs of consecutive nodes written into `runs` ([`axis_runs`]): the rows
/// the system writes, without the general path's merges.
pub fn gimp_runs<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    l: f64,
    runs: &mut [AxisRun; 3],
) -> Result<(), usize> {
    let h = grid.spacing;
    axis_runs(grid, x, 1.0 + l / h, |r| gimp_1d(r, h, l), runs)
}

/// The `basis/gimp` system: rebuilds the connectivity for the current positions.
pub fn gimp_basis<D: Dim>(
    clock: Res<SimClock>,
    grid: Res<Grid<D>>,
    thickness: Option<Res<Thickness>>,
    mut health: ResMut<Health>,
    mut connectivity: ResMut<Connectivity<D>>,
    particles: Query<(&ParticleId, &Position<D>, &InitialVolume), With<Particle>>,
) {
    let (ids, positions, volumes) =
        single_table(particles.contiguous_iter(), "particles").unwrap_or((&[], &[], &[]));
    let grid = &*grid;
    let t = thickness.map_or(1.0, |t| t.0);
    let runs = |p: usize, runs: &mut [AxisRun; 3]| {
        let l = half_width(volumes[p].0, t, D::N, grid.spacing);
        gimp_runs(grid, positions[p].0, l, runs)
    };
    // The rows go straight into the connectivity tables (a failed particle gets none, and
    // its row's value is the axis its domain crosses the grid's edge along).
    let crossed: Vec<Option<usize>> = connectivity.fill_rows(
        positions.len(),
        grid.node_count(),
        |p| {
            let mut axes = [AxisRun::UNIT; 3];
            runs(p, &mut axes).map_or(0, |()| runs_width(&axes))
        },
        || (),
        |_, p, nodes, weights, gradients| {
            let mut axes = [AxisRun::UNIT; 3];
            match runs(p, &mut axes) {
                Ok(()) if write_box_row(grid, &axes, (nodes, weights, gradients)) => None,
                // A node this world does not hold: the general path names it.
                Ok(()) => {
                    let l = half_width(volumes[p].0, t, D::N, grid.spacing);
                    let factors = gimp_axes(grid, positions[p].0, l).ok()?;
                    write_tensor_row(grid, &factors, (nodes, weights, gradients));
                    None
                }
                Err(axis) => Some(axis),
            }
        },
    );
    // The first failed particle, searched on the pool's threads like the rows were filled.
    let first = crossed.par_iter().position_first(Option::is_some);
    if let Some((p, Some(axis))) = first.map(|p| (p, crossed[p])) {
        health.fail(Blowup::new(
            clock.step + 1,
            Stage::Basis,
            format!(
                "particle {} at {}: its GIMP domain reaches past the grid along axis {axis}; \
                 extend the grid by a cell",
                ids[p].0,
                fmt_vector(positions[p].0, D::N)
            ),
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tensor::{assert_box_row_is, assert_consistent_row};
    use fractum_engine::testing::*;

    /// Partition of unity, linear reproduction, Σ∇S̄ = 0 and Σ x_I ⊗ ∇S̄_I = I for a row.
    fn check_consistency<D: Dim>(grid: &Grid<D>, x: D::Vector, l: f64, nodes: usize) {
        let row = gimp_row(grid, x, l).unwrap();
        assert_eq!(row.len(), nodes, "{row:?}");
        assert_consistent_row(grid, x, &row, 1e-14);
    }

    #[test]
    fn rows_are_partitions_of_unity_that_reproduce_linear_fields() {
        let grid = Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [4, 4],
            graded: None,
            window: None,
        };
        let l = 0.125; // two particles per cell
        // Well inside a cell: the four nodes of the cell only, as with the tents.
        check_consistency(&grid, DVec2::new(0.25, 3.25), l, 4);
        // Within l of a grid line along x: a third column of nodes.
        check_consistency(&grid, DVec2::new(0.05, 3.25), l, 6);
        // Near a cell corner: 3 × 3.
        check_consistency(&grid, DVec2::new(0.05, 2.95), l, 9);
        let grid = Grid::<Three> {
            min: DVec3::new(-1.0, 2.0, 0.5),
            spacing: 0.5,
            cells: [4, 4, 2],
            graded: None,
            window: None,
        };
        check_consistency(&grid, DVec3::new(0.05, 2.95, 0.98), l, 27);
        check_consistency(&grid, DVec3::new(0.25, 3.25, 0.75), l, 8);
    }

    /// The rows the system writes from runs are the general path's rows to the bit, and fail
    /// along the same axis, on positions swept across a grid (half and whole cells, where a
    /// row has two or three nodes per axis, and past the faces), for two particle sizes, in
    /// 2D and 3D, on a whole grid and on a rank's window of it.
    #[test]
    fn rows_from_runs_are_the_general_rows_to_the_bit() {
        fn sweep<D: Dim>(grid: &Grid<D>, cells: (f64, f64)) -> usize {
            let mut compared = 0;
            for l in [0.25 * grid.spacing, 0.5 * grid.spacing] {
                for k in 0..=160 {
                    let x = D::Vector::from_fn(|a| {
                        let t = if a == 0 {
                            f64::from(k) / 160.0
                        } else {
                            (f64::from(k) * 0.618_034 * (a + 1) as f64).fract()
                        };
                        grid.min[a] + (cells.0 + t * (cells.1 - cells.0)) * grid.spacing
                    });
                    let mut runs = [AxisRun::UNIT; 3];
                    let general = gimp_row(grid, x, l);
                    match gimp_runs(grid, x, l, &mut runs) {
                        Err(axis) => assert_eq!(general, Err(axis)),
                        Ok(()) => {
                            assert_box_row_is(grid, &runs, &general.unwrap(), &(l, x));
                            compared += 1;
                        }
                    }
                }
            }
            compared
        }
        let plane = Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [8, 8],
            graded: None,
            window: None,
        };
        assert!(sweep(&plane, (-0.5, 8.5)) > 200);
        let window = fractum_engine::resources::NodeWindow {
            first: [2, 1],
            counts: [6, 7],
        };
        assert!(sweep(&plane.windowed(window), (3.0, 6.0)) > 200);
        let space = Grid::<Three> {
            min: DVec3::new(0.1, -0.3, 0.0),
            spacing: 0.1,
            cells: [5, 5, 5],
            graded: None,
            window: None,
        };
        assert!(sweep(&space, (-0.5, 5.5)) > 100);
    }

    /// Inside a cell, away from its faces, the weights are the tents'; across the support's edge
    /// the weight and its slope vanish together (weight ∝ distance², slope ∝ distance).
    #[test]
    fn weights_match_the_tents_inside_and_vanish_smoothly_at_the_edge() {
        let (h, l) = (1.0, 0.25);
        for r in [0.3, 0.5, -0.6] {
            let (s, ds) = gimp_1d(r, h, l);
            assert!((s - (1.0 - f64::abs(r))).abs() < 1e-15);
            assert!((ds + f64::signum(r)).abs() < 1e-15);
        }
        // Continuous value and slope at the breakpoints l, h − l, h + l.
        for edge in [l, h - l, h + l] {
            let (below, above) = (gimp_1d(edge - 1e-9, h, l), gimp_1d(edge + 1e-9, h, l));
            assert!((below.0 - above.0).abs() < 1e-8 && (below.1 - above.1).abs() < 1e-8);
        }
        let near = |gap: f64| gimp_1d(h + l - gap, h, l);
        let (s1, ds1) = near(1e-3);
        let (s2, ds2) = near(2e-3);
        assert!((s2 / s1 - 4.0).abs() < 1e-9 && (ds2 / ds1 - 2.0).abs() < 1e-9);
        // The ratio that drives the update-stress-last velocity gradient stays bounded.
        assert!((ds1 * ds1 / s1 - ds2 * ds2 / s2).abs() < 1e-9);
    }

    /// The system alone on a tiny world: each particle's row sums to one, and a particle whose
    /// domain would reach past the grid stops the run at the basis stage.
    #[test]
    fn the_system_builds_rows_and_reports_a_support_outside_the_grid() {
        let mut world = tiny_world::<Two>(4, 0.25, 1e-3);
        let inside = spawn_particle(
            &mut world,
            DVec2::new(0.6, 0.26),
            DVec2::ZERO,
            1.0,
            0.015625,
        );
        run_system(&mut world, gimp_basis::<Two>);
        let connectivity = world.resource::<Connectivity<Two>>();
        assert_eq!(connectivity.row(0).len(), 6);
        let sum: f64 = connectivity.weights[connectivity.row(0)].iter().sum();
        assert!((sum - 1.0).abs() < 1e-14);
        assert!(world.resource::<Health>().failure.is_none());
        world.get_mut::<Position<Two>>(inside).unwrap().0 = DVec2::new(0.5, 0.01);
        run_system(&mut world, gimp_basis::<Two>);
        let failure = world.resource::<Health>().failure.clone().unwrap();
        assert_eq!(failure.stage, Stage::Basis);
        assert!(failure.message.contains("axis 1"), "{}", failure.message);
    }
}
