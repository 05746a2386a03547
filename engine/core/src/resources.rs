//! Resources shared by the whole step: clock, grid geometry, materials, body force.

use crate::dim::{Dim, Lattice, VectorOps};
use bevy_ecs::prelude::Resource;
use std::sync::Arc;

/// Simulation clock. `step` counts completed steps; `dt` is the size of the step being taken.
#[derive(
    Resource, Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize,
)]
pub struct SimClock {
    /// Completed steps.
    pub step: u64,
    /// Simulated time at the start of the current step.
    pub time: f64,
    /// Size of the current step.
    pub dt: f64,
}

/// Background grid over an axis-aligned box: uniform, or rectilinear (graded) with its own node
/// coordinates along each axis.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct Grid<D: Dim> {
    /// Lower corner.
    pub min: D::Vector,
    /// Node spacing `h` of a uniform grid; the smallest cell width of a graded one (the scale of
    /// ε-neighbourhoods and of default kernel radii).
    pub spacing: f64,
    /// Number of cells along each axis.
    pub cells: D::Cell,
    /// Node coordinates along each axis of a graded grid (`None`: uniform).
    pub graded: Option<Arc<GradedAxes>>,
    /// The nodes this world holds, when not every node (`None`): a rank of a distributed run
    /// holds the nodes its particles reach. Node indices ([`Grid::node_index`]) count the
    /// held nodes; the geometry (corner, coordinates, cells) stays the whole grid's, so a node
    /// is at the same position, to the bit, whichever world holds it.
    pub window: Option<NodeWindow<D>>,
}

/// A box of a grid's nodes: those with lattice coordinates from `first` to `first + counts`
/// (excluded) along each axis, numbered in the grid's order (the first axis fastest), so that
/// the held nodes keep the whole grid's relative order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeWindow<D: Dim> {
    /// Lattice coordinates of the box's first node.
    pub first: D::Cell,
    /// Nodes along each axis.
    pub counts: D::Cell,
}

impl<D: Dim> NodeWindow<D> {
    /// Whether the node with lattice coordinates `node` is in the box.
    pub fn contains(&self, node: D::Cell) -> bool {
        (0..D::N).all(|a| node[a] >= self.first[a] && node[a] < self.first[a] + self.counts[a])
    }
}

/// Node coordinates along each axis of a graded (rectilinear) grid, strictly increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct GradedAxes {
    /// One list per axis, `cells + 1` coordinates each.
    pub coordinates: Vec<Vec<f64>>,
}

impl<D: Dim> Grid<D> {
    /// A uniform grid of `cells` cells of side `spacing` from `min`.
    pub fn uniform(min: D::Vector, spacing: f64, cells: D::Cell) -> Self {
        Self {
            min,
            spacing,
            cells,
            graded: None,
            window: None,
        }
    }

    /// A rectilinear grid with the node coordinates `coordinates[a]` along each axis (each
    /// strictly increasing, at least two). Returns `None` for lists that are not.
    pub fn graded(coordinates: Vec<Vec<f64>>) -> Option<Self> {
        if coordinates.len() != D::N {
            return None;
        }
        let valid = coordinates.iter().all(|c| {
            c.len() >= 2 && c.iter().all(|x| x.is_finite()) && c.windows(2).all(|w| w[1] > w[0])
        });
        if !valid {
            return None;
        }
        let min = D::Vector::from_fn(|a| coordinates[a][0]);
        let cells = D::Cell::from_fn(|a| coordinates[a].len() - 1);
        let spacing = coordinates
            .iter()
            .flat_map(|c| c.windows(2).map(|w| w[1] - w[0]))
            .fold(f64::INFINITY, f64::min);
        Some(Self {
            min,
            spacing,
            cells,
            graded: Some(Arc::new(GradedAxes { coordinates })),
            window: None,
        })
    }

    /// True for a graded (rectilinear) grid.
    pub fn is_graded(&self) -> bool {
        self.graded.is_some()
    }

    /// Coordinate of node `i` along axis `a`.
    #[inline]
    pub fn coordinate(&self, a: usize, i: usize) -> f64 {
        match &self.graded {
            None => self.min[a] + i as f64 * self.spacing,
            Some(g) => g.coordinates[a][i],
        }
    }

    /// Width of cell `i` along axis `a`.
    #[inline]
    pub fn cell_width(&self, a: usize, i: usize) -> f64 {
        match &self.graded {
            None => self.spacing,
            Some(g) => g.coordinates[a][i + 1] - g.coordinates[a][i],
        }
    }

    /// Upper corner.
    pub fn max(&self) -> D::Vector {
        D::Vector::from_fn(|a| self.coordinate(a, self.cells[a]))
    }

    /// Nodes along each axis.
    pub fn nodes_per_axis(&self) -> D::Cell {
        D::Cell::from_fn(|a| self.cells[a] + 1)
    }

    /// The nodes of one layer across `axis`: the product of the other axes' node counts (every
    /// layer of the grid has as many; a rank holds whole layers).
    pub fn nodes_per_layer(&self, axis: usize) -> u64 {
        let all = self.nodes_per_axis();
        (0..D::N)
            .filter(|&a| a != axis)
            .map(|a| all[a] as u64)
            .product()
    }

    /// The nodes this world holds: the window's, or every node of the grid.
    pub fn node_count(&self) -> usize {
        match &self.window {
            Some(window) => window.counts.product(),
            None => self.global_node_count(),
        }
    }

    /// Every node of the grid, held here or not.
    pub fn global_node_count(&self) -> usize {
        self.nodes_per_axis().product()
    }

    /// The grid holding the nodes of `window` only (clamped into the grid).
    pub fn windowed(&self, window: NodeWindow<D>) -> Self {
        let all = self.nodes_per_axis();
        let first = D::Cell::from_fn(|a| window.first[a].min(all[a] - 1));
        let counts = D::Cell::from_fn(|a| window.counts[a].min(all[a] - first[a]).max(1));
        Self {
            window: Some(NodeWindow { first, counts }),
            ..self.clone()
        }
    }

    /// The whole grid: the same geometry, every node held.
    pub fn whole(&self) -> Self {
        Self {
            window: None,
            ..self.clone()
        }
    }

    /// Total cell count.
    pub fn cell_count(&self) -> usize {
        self.cells.product()
    }

    /// Linear index `i + nx (j + ny k)` of the node with lattice coordinates `node` among
    /// the held nodes (counted from the window's first node, `nx`, `ny` the window's counts).
    ///
    /// # Panics
    /// When the node is not held: a rank's window covers every node its particles reach
    /// ([`crate::decomposition::rank_grid`]), so this is a broken invariant, and a
    /// wrong index would corrupt another node's sums silently.
    #[inline]
    pub fn node_index(&self, node: D::Cell) -> usize {
        let (index, held) = self.index_in_window(node);
        if !held {
            self.not_held(node);
        }
        index
    }

    /// [`Grid::node_index`], or `None` for a node this world does not hold.
    #[inline]
    pub fn held_node_index(&self, node: D::Cell) -> Option<usize> {
        let (index, held) = self.index_in_window(node);
        held.then_some(index)
    }

    /// The linear index of `node` among the held nodes, and whether it is held (the index is
    /// meaningless when not). One test for every axis, not a branch per axis: this is on the
    /// path of every particle's every node.
    #[inline]
    fn index_in_window(&self, node: D::Cell) -> (usize, bool) {
        let (first, counts) = match &self.window {
            Some(w) => (w.first, w.counts),
            None => (D::Cell::default(), self.nodes_per_axis()),
        };
        let mut index = 0usize;
        let mut held = true;
        for a in (0..D::N).rev() {
            let local = node[a].wrapping_sub(first[a]);
            held &= local < counts[a];
            index = index.wrapping_mul(counts[a]).wrapping_add(local);
        }
        (index, held)
    }

    #[cold]
    #[inline(never)]
    fn not_held(&self, node: D::Cell) -> ! {
        panic!(
            "node {:?} is outside the nodes this world holds ({:?})",
            node.as_ref(),
            self.window
        )
    }

    /// Lattice coordinates (in the whole grid) of the held node with linear index `index`.
    pub fn node_lattice(&self, index: usize) -> D::Cell {
        let (first, counts) = match &self.window {
            Some(w) => (w.first, w.counts),
            None => (D::Cell::default(), self.nodes_per_axis()),
        };
        let mut rest = index;
        D::Cell::from_fn(|a| {
            let coordinate = rest % counts[a];
            rest /= counts[a];
            first[a] + coordinate
        })
    }

    /// Position of the node with linear index `index`.
    pub fn node_position(&self, index: usize) -> D::Vector {
        let node = self.node_lattice(index);
        D::Vector::from_fn(|a| self.coordinate(a, node[a]))
    }

    /// Position of the node with lattice coordinates `node`.
    pub fn lattice_position(&self, node: D::Cell) -> D::Vector {
        D::Vector::from_fn(|a| self.coordinate(a, node[a]))
    }

    /// Index along axis `a` of the cell holding coordinate `x`, or `None` outside. A point
    /// exactly on the upper boundary belongs to the last cell.
    #[inline]
    pub fn axis_cell(&self, a: usize, x: f64) -> Option<usize> {
        let n = self.cells[a];
        match &self.graded {
            None => {
                let local = (x - self.min[a]) / self.spacing;
                if local.is_nan() || local < 0.0 {
                    return None;
                }
                // `local` is not negative here, so the cast truncates to its floor (without
                // the call `floor` is on the baseline x86-64 target).
                let mut i = local as usize;
                if i == n && local == n as f64 {
                    i -= 1;
                }
                (i < n).then_some(i)
            }
            Some(g) => {
                let c = &g.coordinates[a];
                if x.is_nan() || x < c[0] || x > c[n] {
                    return None;
                }
                // The last node not above x, clamped to the last cell at the upper boundary.
                Some((c.partition_point(|&node| node <= x) - 1).min(n - 1))
            }
        }
    }

    /// Index along axis `a` of the cell holding coordinate `x`, clamped into the grid: a point
    /// below the grid is in the first cell, one above it (or NaN) in the last.
    #[inline]
    pub fn clamped_axis_cell(&self, a: usize, x: f64) -> usize {
        let last = self.cells[a] - 1;
        if self.graded.is_none() {
            // A distributed step asks this of every particle twice: the floor by a signed
            // cast (saturating; an unsigned cast is an instruction sequence on x86-64), the
            // clamp after it.
            let local = (x - self.min[a]) / self.spacing;
            return if local >= 0.0 {
                (local as i64 as usize).min(last)
            } else if local.is_nan() {
                last
            } else {
                0
            };
        }
        self.axis_cell(a, x).unwrap_or_else(|| {
            if x < self.coordinate(a, 0) {
                0
            } else {
                self.cells[a] - 1
            }
        })
    }

    /// Cell containing `x`, or `None` when `x` lies outside the grid box. A point exactly on
    /// the upper boundary belongs to the last cell.
    pub fn cell_of(&self, x: D::Vector) -> Option<D::Cell> {
        let mut cell = D::Cell::default();
        for a in 0..D::N {
            cell[a] = self.axis_cell(a, x[a])?;
        }
        Some(cell)
    }

    /// True when `x` lies inside the grid box (boundary included).
    pub fn contains(&self, x: D::Vector) -> bool {
        self.cell_of(x).is_some()
    }

    /// The smallest cell width along any axis among the cell holding `x` and its neighbours
    /// (the cells a particle's support reaches first): the spacing that bounds the stable step
    /// of a particle at `x`. `spacing` for a uniform grid or a point outside.
    pub fn smallest_width_near(&self, x: D::Vector) -> f64 {
        if self.graded.is_none() {
            return self.spacing;
        }
        let Some(cell) = self.cell_of(x) else {
            return self.spacing;
        };
        let mut smallest = f64::INFINITY;
        for a in 0..D::N {
            let lo = cell[a].saturating_sub(1);
            let hi = (cell[a] + 1).min(self.cells[a] - 1);
            for i in lo..=hi {
                smallest = smallest.min(self.cell_width(a, i));
            }
        }
        smallest
    }

    /// The local node spacing along each axis at `x`: the cell widths interpolated linearly
    /// between nodes (each node takes the mean of its two cells), so it varies continuously
    /// as a particle moves. `spacing` along every axis for a uniform grid.
    pub fn local_spacing(&self, x: D::Vector) -> D::Vector {
        if self.graded.is_none() {
            return D::Vector::splat(self.spacing);
        }
        D::Vector::from_fn(|a| {
            let n = self.cells[a];
            let node_width = |i: usize| {
                let left = if i > 0 {
                    self.cell_width(a, i - 1)
                } else {
                    self.cell_width(a, 0)
                };
                let right = if i < n {
                    self.cell_width(a, i)
                } else {
                    self.cell_width(a, n - 1)
                };
                0.5 * (left + right)
            };
            let xa = x[a].clamp(self.coordinate(a, 0), self.coordinate(a, n));
            let i = self.axis_cell(a, xa).unwrap_or(0);
            let t = ((xa - self.coordinate(a, i)) / self.cell_width(a, i)).clamp(0.0, 1.0);
            (1.0 - t) * node_width(i) + t * node_width(i + 1)
        })
    }
}

/// Marks a pipeline whose damage system degrades the stress tensor itself (only the tensile
/// principal stresses, dfg-partitioning-mpm.md eqs. 26–27: `damage/rankine`,
/// `damage/time_to_failure`): the force transfer then uses the stress as it is, instead of
/// scaling it by `1 − D` (eq. 16 of the eigensoftening paper, for eigenerosion and
/// eigensoftening), and the energy totals take the stored energy as the damage system left it.
/// The two kinds cannot share a pipeline; their installs check.
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DamageInStress;

/// The out-of-plane thickness of a 2D scene (m): particle volumes, and so masses, forces and
/// energies, are for this thickness. 1 in 3D, where volumes are volumes.
#[derive(Resource, Clone, Copy, Debug, PartialEq)]
pub struct Thickness(pub f64);

impl Default for Thickness {
    fn default() -> Self {
        Self(1.0)
    }
}

/// Elastic properties of a named material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name used in the scene.
    pub name: String,
    /// Mass density ρ.
    pub density: f64,
    /// Young's modulus E.
    pub youngs_modulus: f64,
    /// Poisson's ratio ν.
    pub poisson_ratio: f64,
}

impl Material {
    /// A material named `name` with density, Young's modulus and Poisson's ratio.
    pub fn new(name: &str, density: f64, youngs_modulus: f64, poisson_ratio: f64) -> Self {
        Self {
            name: name.to_string(),
            density,
            youngs_modulus,
            poisson_ratio,
        }
    }

    /// Lamé constants (λ, μ).
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        (lambda, mu)
    }

    /// Dilatational (P-) wave speed `sqrt((λ + 2μ)/ρ)`, the fastest signal (the same in plane
    /// strain and in 3D).
    pub fn wave_speed(&self) -> f64 {
        let (lambda, mu) = self.lame();
        ((lambda + 2.0 * mu) / self.density).sqrt()
    }
}

/// The scene's materials, indexed by [`crate::components::MaterialId`].
#[derive(Resource, Clone, Debug, Default)]
pub struct Materials(pub Vec<Material>);

impl Materials {
    /// Largest wave speed over all materials.
    pub fn max_wave_speed(&self) -> f64 {
        self.0.iter().map(Material::wave_speed).fold(0.0, f64::max)
    }
}

/// How much of the central-difference stable time step the installed systems allow.
///
/// The engine's limit is `h / (√d (c + |v|))`: the central-difference limit of a lumped-mass
/// multilinear grid in `d` dimensions. An integrator with a smaller stability region lowers
/// `factor` at install (through [`crate::registry::Installer::restrict_time_step`]) and says why.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct TimeStepLimit {
    /// Fraction of the central-difference limit, in (0, 1].
    pub factor: f64,
    /// Which system set it and why (empty when nothing restricts it).
    pub reason: String,
}

impl Default for TimeStepLimit {
    fn default() -> Self {
        Self {
            factor: 1.0,
            reason: String::new(),
        }
    }
}

impl TimeStepLimit {
    /// The stable step in `dimensions` dimensions for spacing `h` and fastest signal speed
    /// `speed` (wave plus material): `factor · h / (√d · speed)`.
    pub fn stable_step(&self, dimensions: usize, h: f64, speed: f64) -> f64 {
        if speed > 0.0 {
            self.factor * h / ((dimensions as f64).sqrt() * speed)
        } else {
            f64::INFINITY
        }
    }
}

/// Uniform body force per unit mass (an acceleration, e.g. gravity).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct BodyForce<D: Dim>(pub D::Vector);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dim::{Three, Two};
    use glam::{DVec2, DVec3};

    #[test]
    fn grid_indexing_round_trips() {
        let grid = Grid::<Two> {
            min: DVec2::new(-1.0, 0.0),
            spacing: 0.5,
            cells: [4, 2],
            graded: None,
            window: None,
        };
        assert_eq!(grid.node_count(), 15);
        assert_eq!(grid.max(), DVec2::new(1.0, 1.0));
        assert_eq!(grid.node_index([2, 1]), 7);
        assert_eq!(grid.node_position(7), DVec2::new(0.0, 0.5));
        assert_eq!(grid.cell_of(DVec2::new(1.0, 1.0)), Some([3, 1]));
        assert_eq!(grid.cell_of(DVec2::new(-0.99, 0.01)), Some([0, 0]));
        assert_eq!(grid.cell_of(DVec2::new(1.01, 0.5)), None);
        assert_eq!(grid.cell_of(DVec2::new(0.0, f64::NAN)), None);
    }

    /// The clamped cell is the cell [`Grid::axis_cell`] gives, or the first cell below the
    /// grid and the last above it or for NaN: the uniform grid's own branch agrees with that
    /// definition at faces, the bounds, far outside and at infinities.
    #[test]
    fn the_clamped_cell_is_the_cell_or_the_nearest_end() {
        let grid = Grid::<Two>::uniform(DVec2::new(-0.104, 0.0), 1.0e-3, [208, 104]);
        let reference = |x: f64| {
            grid.axis_cell(0, x)
                .unwrap_or(if x < grid.coordinate(0, 0) { 0 } else { 207 })
        };
        let mut points = vec![f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e300, -1e300];
        for i in 0..=208 {
            let face = grid.coordinate(0, i);
            points.extend([face, face.next_up(), face.next_down(), face + 0.5e-3]);
        }
        for x in points {
            assert_eq!(grid.clamped_axis_cell(0, x), reference(x), "x = {x:e}");
        }
        assert_eq!(grid.clamped_axis_cell(0, -1.0), 0);
        assert_eq!(grid.clamped_axis_cell(0, 0.104), 207);
        assert_eq!(grid.clamped_axis_cell(0, f64::NAN), 207);
    }

    #[test]
    fn grid_indexing_round_trips_in_3d() {
        let grid = Grid::<Three> {
            min: DVec3::new(0.0, -1.0, 2.0),
            spacing: 0.25,
            cells: [4, 2, 3],
            graded: None,
            window: None,
        };
        assert_eq!(grid.node_count(), 5 * 3 * 4);
        assert_eq!(grid.cell_count(), 24);
        for index in 0..grid.node_count() {
            assert_eq!(grid.node_index(grid.node_lattice(index)), index);
        }
        assert_eq!(grid.node_index([1, 2, 3]), 1 + 5 * (2 + 3 * 3));
        assert_eq!(
            grid.node_position(grid.node_index([1, 2, 3])),
            DVec3::new(0.25, -0.5, 2.75)
        );
        assert_eq!(grid.max(), DVec3::new(1.0, -0.5, 2.75));
        assert_eq!(grid.cell_of(grid.max()), Some([3, 1, 2]));
        assert_eq!(grid.cell_of(DVec3::new(0.3, -0.9, 2.0)), Some([1, 0, 0]));
        assert_eq!(grid.cell_of(DVec3::new(0.3, -0.9, 1.99)), None);
    }

    #[test]
    fn a_window_numbers_its_nodes_in_the_grid_order_at_the_grid_positions() {
        let grid = Grid::<Three>::uniform(DVec3::new(0.0, -1.0, 2.0), 0.25, [4, 2, 3]);
        let window = NodeWindow {
            first: [1, 0, 2],
            counts: [3, 3, 2],
        };
        let held = grid.windowed(window);
        assert_eq!(held.node_count(), 18);
        assert_eq!(held.global_node_count(), grid.node_count());
        let mut previous = None;
        for index in 0..held.node_count() {
            let node = held.node_lattice(index);
            assert!(window.contains(node));
            assert_eq!(held.node_index(node), index);
            // The same bits as the whole grid's node.
            assert_eq!(
                held.node_position(index),
                grid.node_position(grid.node_index(node))
            );
            // Ascending in the whole grid's numbering.
            let global = grid.node_index(node);
            assert!(previous.is_none_or(|p| p < global));
            previous = Some(global);
        }
        assert_eq!(held.held_node_index([0, 0, 2]), None);
        assert_eq!(held.held_node_index([1, 0, 4]), None);
        assert_eq!(held.whole(), grid);
        // A window reaching past the grid is clamped into it.
        let clamped = grid.windowed(NodeWindow {
            first: [0, 0, 3],
            counts: [9, 9, 9],
        });
        assert_eq!(clamped.node_count(), 5 * 3);
    }

    #[test]
    #[should_panic(expected = "outside the nodes this world holds")]
    fn a_node_outside_the_window_is_refused_rather_than_numbered() {
        let grid = Grid::<Two>::uniform(DVec2::ZERO, 1.0, [4, 4]);
        let held = grid.windowed(NodeWindow {
            first: [0, 2],
            counts: [5, 3],
        });
        held.node_index([1, 1]);
    }

    #[test]
    fn wave_speed_reduces_to_bar_speed_without_poisson_effect() {
        let m = Material::new("bar", 1.0, 100.0, 0.0);
        assert!((m.wave_speed() - 10.0).abs() < 1e-12);
    }

    #[test]
    fn stable_step_follows_the_square_root_of_the_dimension() {
        let limit = TimeStepLimit::default();
        assert_eq!(limit.stable_step(2, 1.0, 1.0), 1.0 / 2f64.sqrt());
        assert_eq!(limit.stable_step(3, 1.0, 1.0), 1.0 / 3f64.sqrt());
        assert_eq!(limit.stable_step(3, 1.0, 0.0), f64::INFINITY);
    }
}
