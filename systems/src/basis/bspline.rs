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
//! - The grid's edges: boundary-modified splines, as in the B-spline MPM literature (Steffen,
//!   Kirby & Berzins 2008). The spline of a node one cell beyond the grid's face is folded
//!   onto the face's nodes by linear extrapolation of the nodal field (`v₋₁ = 2 v₀ − v₁`):
//!   the edge node's weight is 1 on the face (the basis interpolates there, so a boundary
//!   condition held on the face's nodes holds at the face, as with the tents), rows stay
//!   partitions of unity that reproduce linear fields with no negative weight, and only the
//!   first half cell (quadratic) or cell (cubic) from the face differs from the cardinal
//!   splines. So particles may fill the grid up to its faces, as with every other basis; no
//!   ghost layer is needed. A condition held on nodes inside the grid acts over the splines'
//!   whole support (three or four node layers), not on one plane: put held boundaries on the
//!   grid's faces. A graded grid is refused (the splines here need one spacing).
//! - Weights and gradients are computed once per particle per step into the connectivity
//!   tables, which every transfer of the step reads.

use super::tensor::{
    AxisFactors, AxisRun, MAX_AXIS_NODES, ceil_index, write_box_row, write_tensor_row,
};
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
        doc: "2 (quadratic, 3 nodes per axis) or 3 (cubic, 4 nodes per axis)",
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

    /// Lattice nodes along an axis that may lie within reach of a point: `2 × reach + 1`,
    /// `order + 2`.
    pub fn candidates(&self) -> usize {
        self.order as usize + 2
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

/// The per-axis factors of the row of a particle at `x`: the cardinal splines of the nodes
/// whose support holds it, with the spline of a node one beyond the grid's edge folded onto the
/// edge (see [`fold_ghost`]). No node at all (width 0) when `x` lies outside the grid, as the
/// tents give none there: the engine's health check then stops the run or removes the particle.
pub fn spline_axes<D: Dim>(grid: &Grid<D>, x: D::Vector, params: &BsplineParams) -> AxisFactors {
    let h = grid.spacing;
    let reach = params.reach();
    let lattice = grid.nodes_per_axis();
    let candidates = params.candidates();
    let mut factors = AxisFactors::empty();
    for a in 0..D::N {
        let s = (x[a] - grid.min[a]) / h;
        let last = lattice[a] as isize - 1;
        if !(0.0..=last as f64).contains(&s) {
            return AxisFactors::empty();
        }
        let low = ceil_index(s - reach);
        let interior = low >= 0 && low + candidates as isize - 1 <= last;
        for node in (low..).take(candidates) {
            let r = x[a] - (grid.min[a] + node as f64 * h);
            let (weight, slope) = spline_1d(params.order, r, h);
            if weight <= 0.0 {
                continue;
            }
            if interior {
                // No ghost to fold: the nodes come once each, in lattice order.
                factors.push(a, node as usize, weight, slope);
            } else {
                for (target, share) in fold_ghost(node, last) {
                    factors.add(a, target, share * weight, share * slope);
                }
            }
        }
    }
    factors
}

/// The runs of the row of a particle at `x` whose splines all lie on the grid's nodes (none
/// to fold: [`fold_ghost`]), the nodes and values [`spline_axes`] gives it, evaluated the same
/// way; `None` for a particle by the grid's faces or outside the grid, which
/// [`spline_axes`] handles. Most particles of a scene are interior: their rows then skip the
/// folding's merges and go to [`write_box_row`].
///
/// The runs are written into `runs` (the axes past the dimension left as they are, which
/// should be [`AxisRun::UNIT`]) rather than returned: this is on the path of every particle of
/// every step.
pub fn interior_runs<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    params: &BsplineParams,
    runs: &mut [AxisRun; 3],
) -> bool {
    let h = grid.spacing;
    let reach = params.reach();
    let lattice = grid.nodes_per_axis();
    let candidates = params.candidates();
    for (a, run) in runs.iter_mut().enumerate().take(D::N) {
        let s = (x[a] - grid.min[a]) / h;
        let last = lattice[a] as isize - 1;
        let low = ceil_index(s - reach);
        if !(0.0..=last as f64).contains(&s) || low < 0 || low + candidates as isize - 1 > last {
            return false;
        }
        run.count = 0;
        // The positive splines are consecutive: |ξ| falls, then rises, along the candidates.
        for node in (low..).take(candidates) {
            let r = x[a] - (grid.min[a] + node as f64 * h);
            let (weight, slope) = spline_1d(params.order, r, h);
            if weight > 0.0 && !run.push(node as usize, weight, slope) {
                return false;
            }
        }
    }
    true
}

/// The width of the row [`spline_axes`] gives a particle at `x`, found without evaluating a
/// spline: the first pass of the connectivity's fill, which only sizes the rows, so that each
/// particle's splines are evaluated once per step, in the second. A node counts where its
/// spline is positive, `|r| / h < reach`: the quadratic spline is at least ½ (1.5 − |ξ|)² there,
/// and the cubic (2 − |ξ|)³ / 6 or ⅙, both far above the smallest f64 for any `|ξ|` below its
/// reach that an f64 can hold; its folded targets count once each, as [`AxisFactors::add`]
/// merges them.
pub fn spline_width<D: Dim>(grid: &Grid<D>, x: D::Vector, params: &BsplineParams) -> usize {
    let h = grid.spacing;
    let reach = params.reach();
    let lattice = grid.nodes_per_axis();
    let candidates = params.candidates();
    let mut width = 1;
    for a in 0..D::N {
        let s = (x[a] - grid.min[a]) / h;
        let last = lattice[a] as isize - 1;
        if !(0.0..=last as f64).contains(&s) {
            return 0;
        }
        let low = ceil_index(s - reach);
        let interior = low >= 0 && low + candidates as isize - 1 <= last;
        let mut targets = [0usize; MAX_AXIS_NODES];
        let mut count = 0;
        for node in (low..).take(candidates) {
            let r = x[a] - (grid.min[a] + node as f64 * h);
            if (r / h).abs() >= reach {
                continue;
            }
            if interior {
                // Distinct nodes, none folded ([`AxisFactors::push`] in `spline_axes`).
                count = (count + 1).min(MAX_AXIS_NODES);
                continue;
            }
            for (target, _) in fold_ghost(node, last) {
                if !targets[..count].contains(&target) && count < MAX_AXIS_NODES {
                    targets[count] = target;
                    count += 1;
                }
            }
        }
        width *= count;
    }
    width
}

/// Where the spline of lattice index `node` goes on an axis whose last node is `last`: to
/// itself inside the grid; from the ghost one beyond an edge (index `−1` or `last + 1`) to the
/// edge node twice and its neighbour inside minus once, the linear extrapolation
/// `v_ghost = 2 v_edge − v_inner` of the nodal field. This keeps the partition of unity and
/// the linear reproduction, makes every weight at the face interpolate (`N_edge = 1` there,
/// so a condition held on the edge nodes holds on the face), and leaves the weights positive
/// and C¹ (quadratic) or C² (cubic) inside: only the first half cell (quadratic) or cell
/// (cubic) from the face changes, where the edge node's spline becomes `1 − ξ` (quadratic).
/// A particle inside the grid never reaches an index further out.
pub fn fold_ghost(node: isize, last: isize) -> impl Iterator<Item = (usize, f64)> {
    let folded = if node < 0 {
        [(0, 2.0), (1, -1.0)]
    } else if node > last {
        [(last, 2.0), (last - 1, -1.0)]
    } else {
        [(node, 1.0), (node, 0.0)]
    };
    folded
        .into_iter()
        .filter(|(_, share)| *share != 0.0)
        .map(|(target, share)| (target as usize, share))
}

/// The `basis/bspline` system: rebuilds the connectivity for the current positions.
pub fn bspline_basis<D: Dim>(
    grid: Res<Grid<D>>,
    params: Res<BsplineParams>,
    mut connectivity: ResMut<Connectivity<D>>,
    particles: Query<&Position<D>, With<Particle>>,
) {
    let positions = single_table(particles.contiguous_iter(), "particles").unwrap_or(&[]);
    let (grid, params) = (&*grid, &*params);
    // The rows go straight into the connectivity tables; a particle outside the grid gets none.
    connectivity.fill_rows(
        positions.len(),
        grid.node_count(),
        |p| spline_width(grid, positions[p].0, params),
        || (),
        |_, p, nodes, weights, gradients| {
            let x = positions[p].0;
            let mut runs = [AxisRun::UNIT; 3];
            if !(interior_runs(grid, x, params, &mut runs)
                && write_box_row(grid, &runs, (nodes, weights, gradients)))
            {
                write_tensor_row(
                    grid,
                    &spline_axes(grid, x, params),
                    (nodes, weights, gradients),
                );
            }
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::tensor::assert_consistent_row;
    use crate::basis::tensor::{assert_box_row_is, tensor_row};
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
        let row = tensor_row(grid, &spline_axes(grid, x, &params));
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

    /// Near and on the grid's faces the folded splines are still consistent rows, with fewer
    /// nodes along the folded axis, on a grid of one cell along an axis too (where they are
    /// the tents).
    #[test]
    fn rows_stay_consistent_up_to_the_grid_faces() {
        let grid = Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [8, 1],
            graded: None,
            window: None,
        };
        // (x, quadratic nodes, cubic nodes): the lower face (where the cubic spline of the
        // third node ends), inside the folded half cell (quadratic) and cell (cubic), just past
        // them, and by the upper face; y on the single cell's axis (its 2 nodes).
        for (x, quadratic, cubic) in [
            (-1.0, 2, 2),
            (-0.9, 2, 3),
            (-0.7, 3, 3),
            (-0.4, 3, 4),
            (2.95, 2, 3),
            (3.0, 2, 2),
        ] {
            for y in [2.0, 2.1, 2.5] {
                check_consistency(&grid, DVec2::new(x, y), 2, 2 * quadratic);
                check_consistency(&grid, DVec2::new(x, y), 3, 2 * cubic);
            }
        }
    }

    /// The rows' widths found without the splines are those of the splines' rows: on a sweep
    /// of positions across a small grid, its faces and beyond, and on the half and whole
    /// cells where a node's support starts or ends, in 2D and 3D, for both orders.
    #[test]
    fn row_widths_without_the_splines_are_the_rows_widths() {
        fn sweep<D: Dim>(grid: &Grid<D>) {
            let top = grid.min[0] + grid.spacing * grid.cells[0] as f64;
            let samples: Vec<f64> = (-8..=8 * grid.cells[0] as i32 + 8)
                .map(|k| grid.min[0] + f64::from(k) * grid.spacing / 8.0)
                .chain([top, top + 1e-12, grid.min[0] - 1e-12, grid.min[0] + 1e-300])
                .collect();
            for order in [2, 3] {
                let params = BsplineParams { order };
                for (i, &a) in samples.iter().enumerate() {
                    // Every sample on the first axis, a few on the others.
                    let x = D::Vector::from_fn(|axis| {
                        if axis == 0 {
                            a
                        } else {
                            samples[(i * 7 + 3 * axis) % samples.len()]
                        }
                    });
                    assert_eq!(
                        spline_width(grid, x, &params),
                        spline_axes(grid, x, &params).width(D::N),
                        "order {order} at {x:?}"
                    );
                }
            }
        }
        sweep(&Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.5,
            cells: [6, 6],
            graded: None,
            window: None,
        });
        sweep(&Grid::<Three> {
            min: DVec3::new(0.1, -0.3, 0.0),
            spacing: 0.1,
            cells: [5, 5, 5],
            graded: None,
            window: None,
        });
    }

    /// The rows of interior particles, written from their runs, are the general path's rows to
    /// the bit (nodes, weights and every gradient component), for both orders, in 2D and 3D,
    /// on a whole grid and on a rank's window of it; on positions swept across the grid, its
    /// half and whole cells (where a run has one node fewer) and its faces (no runs there).
    #[test]
    fn interior_rows_are_the_general_rows_to_the_bit() {
        // Positions `cells.0` to `cells.1` cells from the grid's corner along each axis.
        fn sweep<D: Dim>(grid: &Grid<D>, cells: (f64, f64)) -> (usize, usize) {
            let (mut interior, mut folded) = (0, 0);
            let span = cells.1 - cells.0;
            for order in [2, 3] {
                let params = BsplineParams { order };
                for k in 0..=240 {
                    let x = D::Vector::from_fn(|a| {
                        let offset = if a == 0 {
                            f64::from(k) * span / 240.0
                        } else {
                            (f64::from(k) * 0.618_034 * (a + 1) as f64).fract() * span
                        };
                        grid.min[a] + (cells.0 + offset) * grid.spacing
                    });
                    let expected = tensor_row(grid, &spline_axes(grid, x, &params));
                    let mut runs = [AxisRun::UNIT; 3];
                    if !interior_runs(grid, x, &params, &mut runs) {
                        folded += 1;
                        continue;
                    }
                    assert_box_row_is(grid, &runs, &expected, &(order, x));
                    interior += 1;
                }
            }
            (interior, folded)
        }
        let plane = Grid::<Two> {
            min: DVec2::new(-1.0, 2.0),
            spacing: 0.25,
            cells: [12, 12],
            graded: None,
            window: None,
        };
        // The whole grid, faces included; then a window of nodes 3..11 × 2..12, swept where a
        // particle's nodes all lie in it (two cells in from its edges).
        let (interior, folded) = sweep(&plane, (0.0, 12.0));
        assert!(interior > 100 && folded > 20, "{interior} {folded}");
        let window = fractum_engine::resources::NodeWindow {
            first: [3, 2],
            counts: [9, 11],
        };
        let (interior, _) = sweep(&plane.windowed(window), (5.0, 9.0));
        assert!(interior > 100, "{interior}");
        let space = Grid::<Three> {
            min: DVec3::new(0.1, -0.3, 0.0),
            spacing: 0.1,
            cells: [7, 7, 7],
            graded: None,
            window: None,
        };
        let (interior, folded) = sweep(&space, (0.0, 7.0));
        assert!(interior > 50 && folded > 20, "{interior} {folded}");
    }

    /// The rounding up without `ceil` is `ceil` cast, for every kind of value.
    #[test]
    fn ceil_index_is_ceil_cast() {
        let mut values = vec![
            0.0,
            -0.0,
            0.3,
            -0.3,
            -0.5,
            1.0,
            -1.0,
            2.0 + f64::EPSILON * 2.0,
            2.0 - f64::EPSILON,
            -1.5,
            4.5e15 + 0.5,
            9.223_372_036_854_775e18,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        values.extend((-40..40).map(|k| f64::from(k) * 0.173));
        for value in values {
            assert_eq!(ceil_index(value), value.ceil() as isize, "{value}");
        }
    }

    /// On the face the edge node's weight is one (a held face holds there); inside, the folded
    /// quadratic spline is `1 − ξ` over the first half cell and the cardinal one from there on,
    /// with value and slope continuous where they meet; outside the grid a particle gets no
    /// node.
    #[test]
    fn folded_splines_interpolate_on_the_face_and_join_the_cardinal_ones() {
        let grid = Grid::<Two> {
            min: DVec2::ZERO,
            spacing: 1.0,
            cells: [6, 6],
            graded: None,
            window: None,
        };
        let edge_node = |x: f64, order: u32| {
            let row = tensor_row(
                &grid,
                &spline_axes(&grid, DVec2::new(x, 3.0), &BsplineParams { order }),
            );
            let node = grid.node_index([0, 3]) as u32;
            let spline_at_y = spline_1d(order, 0.0, 1.0).0;
            row.iter()
                .find(|e| e.0 == node)
                .map_or((0.0, 0.0), |e| (e.1 / spline_at_y, e.2.x / spline_at_y))
        };
        for order in [2, 3] {
            assert!((edge_node(0.0, order).0 - 1.0).abs() < 1e-15);
        }
        for x in [0.0, 0.1, 0.3, 0.49] {
            let (weight, slope) = edge_node(x, 2);
            assert!((weight - (1.0 - x)).abs() < 1e-14 && (slope + 1.0).abs() < 1e-14);
        }
        let (below, above) = (edge_node(0.5 - 1e-9, 2), edge_node(0.5 + 1e-9, 2));
        assert!((below.0 - above.0).abs() < 1e-8 && (below.1 - above.1).abs() < 1e-8);
        assert!((edge_node(0.8, 2).0 - quadratic(0.8).0).abs() < 1e-15);
        let (below, above) = (edge_node(1.0 - 1e-9, 3), edge_node(1.0 + 1e-9, 3));
        assert!((below.0 - above.0).abs() < 1e-8 && (below.1 - above.1).abs() < 1e-8);
        for outside in [-1e-9, 6.0 + 1e-9] {
            let axes = spline_axes(&grid, DVec2::new(outside, 3.0), &BsplineParams::default());
            assert_eq!(axes.width(2), 0);
        }
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
            let row = tensor_row(&grid, &spline_axes(&grid, DVec2::new(x, 4.3), &params));
            let node = grid.node_index([4, 4]) as u32;
            row.iter()
                .find(|e| e.0 == node)
                .map_or(DVec2::ZERO, |e| e.2)
        };
        assert!((gradient_at(4.0 - 1e-9) - gradient_at(4.0 + 1e-9)).length() < 1e-8);
    }

    /// The system alone on a tiny world, in both dimensions: each particle's row sums to one,
    /// within the folded half cell by the grid's face too (with two nodes along that axis), and
    /// a particle outside the grid gets no row, as with the tents.
    fn the_system_builds_rows_up_to_the_grid_faces<D: Dim>()
    where
        D::Vector: SpaceVector,
    {
        let mut world = tiny_world::<D>(8, 0.25, 1e-3);
        world.insert_resource(BsplineParams::default());
        let mut near_face = D::Vector::splat(1.1);
        near_face[D::N - 1] = 0.1;
        let mut outside = D::Vector::splat(1.1);
        outside[0] = -0.01;
        for x in [D::Vector::splat(1.1), near_face, outside] {
            spawn_particle(&mut world, x, D::Vector::ZERO, 1.0, 0.015625);
        }
        run_system(&mut world, bspline_basis::<D>);
        let connectivity = world.resource::<Connectivity<D>>();
        let widths = [3usize.pow(D::N as u32), 2 * 3usize.pow(D::N as u32 - 1), 0];
        for (p, width) in widths.into_iter().enumerate() {
            assert_eq!(connectivity.row(p).len(), width, "particle {p}");
            if width > 0 {
                let sum: f64 = connectivity.weights[connectivity.row(p)].iter().sum();
                assert!((sum - 1.0).abs() < 1e-14);
            }
        }
    }

    #[test]
    fn the_system_builds_rows_up_to_the_grid_faces_in_2d() {
        the_system_builds_rows_up_to_the_grid_faces::<Two>();
    }

    #[test]
    fn the_system_builds_rows_up_to_the_grid_faces_in_3d() {
        the_system_builds_rows_up_to_the_grid_faces::<Three>();
    }
}
