//! The numerical kernels of `basis/mls` and `predictor/mls` (not a system): where a particle's
//! quadratic B-spline stencil starts, its weights evaluated from that, the particle-to-grid
//! scatter in cell slabs, and the grid-to-particle gather of `v_p` and `C_p`.
//!
//! - **Stencil.** Along each axis the three nodes from `⌊ξ − ½⌋` with the cardinal quadratic
//!   weights `½(3/2 − f)²`, `¾ − (f − 1)²`, `½(f − ½)²` (`f` the particle's distance from the
//!   first node in cells). Within half a cell of a grid face the ghost node beyond the face is
//!   folded onto the face's two nodes (`v₋₁ = 2 v₀ − v₁`), as `basis/bspline` does
//!   ([`crate::basis::bspline::fold_ghost`]), so the weights are the same.
//! - **Inertia.** `D_p = Σ N (x_I − x_p) ⊗ (x_I − x_p)` is diagonal for a tensor-product row;
//!   inside the grid each diagonal entry is `h²/4` exactly (the cardinal quadratic spline's
//!   second moment). On a folded axis it is summed from the folded weights: there the MLS
//!   gradient `N D_p⁻¹ (x_I − x_p)` is the tents' gradient, `∓1/h`.
//! - **Scatter.** Each particle adds `N (m, q + A (x_I − x_p))` to its nine (27) nodes. The
//!   particles are bucketed by the row of their first node along the last axis (a stable
//!   counting sort, so within a bucket they keep their index order), [`SLAB_ROWS`] rows per
//!   slab. A slab writes `SLAB_ROWS + 2` node rows, so slabs two apart never share a node:
//!   the even slabs run in parallel, then the odd ones. Every node then receives its sums in
//!   one fixed order, whatever the number of threads.

pub use super::slab_order::{SLAB_ROWS, SlabOrder};
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// The node offsets `o` along an axis of the stencil, as numbers.
const OFFSETS: [f64; 3] = [0.0, 1.0, 2.0];

/// The second moment `Σ N (x_I − x_p)²` of the cardinal quadratic spline, in cells².
const INTERIOR_INERTIA: f64 = 0.25;

/// How far outside `[0, last]`, in cells, a particle still counts as on the grid's face: the
/// round-off of `(x − x_min) / h` for a particle the grid holds ([`Grid::contains`]).
const FACE_TOLERANCE: f64 = 1e-9;

/// Where one axis of a particle's stencil starts: the lattice index (in the whole grid) of the
/// first of its three nodes and the particle's distance from it, in cells (in `[0, 2]`), for a
/// particle at `s` cells from the grid's first node line on an axis whose last node has index
/// `last` (at least 2); `None` outside `[0, last]` (or NaN). A particle within round-off of a
/// face is put on it. The first node is `⌊s − ½⌋`, moved inside the grid within half a cell of
/// a face, where the ghost beyond the face is folded ([`axis_weights`]).
#[inline(always)]
pub fn axis_origin(s: f64, last: usize) -> Option<(usize, f64)> {
    // Signed conversions only: each is one instruction on x86-64, where an unsigned one is a
    // sequence (this runs once per particle and axis every step).
    let last = last as i64;
    let end = last as f64;
    if !(s >= -FACE_TOLERANCE && s <= end + FACE_TOLERANCE) {
        return None;
    }
    let s = s.max(0.0).min(end);
    // ⌊s − ½⌋ + 1 = ⌊s + ½⌋ by truncation (s + ½ > 0): no call to libm's floor on CPUs without
    // SSE4.1's rounding instructions (the portable x86-64 baseline).
    let above = (s + 0.5) as i64;
    let first = (above - 1).max(0).min(last - 2);
    Some((first as usize, s - first as f64))
}

/// The three weights of one axis and `h² / D_aa` for a particle `distance` cells from the
/// first node ([`axis_origin`]): the cardinal quadratic splines inside the grid
/// (`D_aa = h²/4`); within half a cell of a face (`distance < ½` or `> 3/2`) the ghost node's
/// spline folded onto the face's two nodes, `v_ghost = 2 v_face − v_inner`, as
/// [`crate::basis::bspline::fold_ghost`] does, with `D_aa` summed from the folded weights (0 on
/// the face itself, where the row is a single node's, and then `h²/D_aa` is taken as 0).
#[inline(always)]
pub fn axis_weights(distance: f64) -> ([f64; 3], f64) {
    let spline = |f: f64| {
        [
            0.5 * (1.5 - f) * (1.5 - f),
            0.75 - (f - 1.0) * (f - 1.0),
            0.5 * (f - 0.5) * (f - 0.5),
        ]
    };
    let weights = if distance < 0.5 {
        let w = spline(distance + 1.0);
        [w[1] + 2.0 * w[0], w[2] - w[0], 0.0]
    } else if distance > 1.5 {
        let w = spline(distance - 1.0);
        [0.0, w[0] - w[2], w[1] + 2.0 * w[2]]
    } else {
        return (spline(distance), 1.0 / INTERIOR_INERTIA);
    };
    let inertia: f64 = (0..3)
        .map(|o| weights[o] * (OFFSETS[o] - distance) * (OFFSETS[o] - distance))
        .sum();
    (weights, if inertia > 1e-12 { 1.0 / inertia } else { 0.0 })
}

/// The held nodes' lattice: where the grid is, and how node indices step along each axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lattice<D: Dim> {
    /// Corner of the grid.
    pub min: D::Vector,
    /// Node spacing.
    pub spacing: f64,
    /// `1 / h`.
    pub inverse_spacing: f64,
    /// Last node index of the whole grid along each axis.
    pub last: [usize; 3],
    /// Lattice coordinates of the first held node.
    pub first: [usize; 3],
    /// Held nodes along each axis (1 beyond the dimension).
    pub counts: [usize; 3],
    /// Step of the linear node index along each axis (0 beyond the dimension).
    pub strides: [usize; 3],
}

impl<D: Dim> Lattice<D> {
    /// The lattice of a uniform grid's held nodes.
    pub fn of(grid: &Grid<D>) -> Self {
        let all = grid.nodes_per_axis();
        let (first, counts) = match &grid.window {
            Some(w) => (w.first, w.counts),
            None => (D::Cell::default(), all),
        };
        let mut lattice = Self {
            min: grid.min,
            spacing: grid.spacing,
            inverse_spacing: 1.0 / grid.spacing,
            last: [0; 3],
            first: [0; 3],
            counts: [1; 3],
            strides: [0; 3],
        };
        let mut stride = 1;
        for a in 0..D::N {
            lattice.last[a] = all[a] - 1;
            lattice.first[a] = first[a];
            lattice.counts[a] = counts[a];
            lattice.strides[a] = stride;
            stride *= counts[a];
        }
        lattice
    }

    /// Held nodes.
    pub fn node_count(&self) -> usize {
        self.counts.iter().product()
    }

    /// Held node rows along the last axis.
    pub fn rows(&self) -> usize {
        self.counts[D::N - 1]
    }

    /// Nodes in one row (a line in 2D, a plane in 3D).
    pub fn row_len(&self) -> usize {
        self.strides[D::N - 1]
    }
}

/// Where a particle's stencil starts, found once per step by `basis/mls`: the first node and
/// the particle's distance from it along each axis, in cells.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StencilOrigin<D: Dim> {
    /// Linear index, among the held nodes, of the first node (`u32::MAX`: outside the grid).
    pub node: u32,
    /// Distance of the particle from the first node along each axis, in cells (in `[0, 2]`).
    pub distance: D::Vector,
}

impl<D: Dim> StencilOrigin<D> {
    /// The origin of a particle outside the grid: no stencil.
    pub const OUTSIDE: Self = Self {
        node: u32::MAX,
        distance: D::Vector::ZERO,
    };
}

/// The origin of the stencil of a particle at `x`, and the held row of its first node along
/// the last axis, or `None` outside the grid.
///
/// # Panics
/// When a node of the stencil is not held: a rank's window holds every node within the
/// declared support of its particles, so this is a broken invariant.
#[inline(always)]
pub fn locate<D: Dim>(lattice: &Lattice<D>, x: D::Vector) -> Option<(StencilOrigin<D>, usize)> {
    let mut node = 0;
    let mut row = 0;
    let mut distance = [0.0; 3];
    for a in 0..D::N {
        let s = (x[a] - lattice.min[a]) * lattice.inverse_spacing;
        let (first, d) = axis_origin(s, lattice.last[a])?;
        let local = first.wrapping_sub(lattice.first[a]);
        assert!(
            local.wrapping_add(2) < lattice.counts[a],
            "basis/mls: the stencil of a particle at {:?} leaves the held nodes",
            x.to_3d()
        );
        node += local * lattice.strides[a];
        row = local;
        distance[a] = d;
    }
    let origin = StencilOrigin {
        node: u32::try_from(node).expect("held nodes are counted in u32"),
        distance: D::Vector::from_fn(|a| distance[a]),
    };
    Some((origin, row))
}

/// A particle's stencil: its first node and the three weights of every axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stencil<D: Dim> {
    /// Linear index, among the held nodes, of the first node.
    pub node: usize,
    /// Weights of each axis (`[1, 0, 0]` beyond the dimension).
    pub weights: [[f64; 3]; 3],
    /// `x_first − x_p`, the offset of the first node from the particle.
    pub offset: D::Vector,
    /// The diagonal of `D_p⁻¹`.
    pub inverse_inertia: D::Vector,
}

/// The stencil from its origin, or `None` for a particle outside the grid.
#[inline(always)]
pub fn stencil_at<D: Dim>(lattice: &Lattice<D>, origin: &StencilOrigin<D>) -> Option<Stencil<D>> {
    if origin.node == u32::MAX {
        return None;
    }
    let (h, inverse_h) = (lattice.spacing, lattice.inverse_spacing);
    let mut weights = [[1.0, 0.0, 0.0]; 3];
    let mut inverse_inertia = [0.0; 3];
    for a in 0..D::N {
        let (w, inverse) = axis_weights(origin.distance[a]);
        weights[a] = w;
        inverse_inertia[a] = inverse * inverse_h * inverse_h;
    }
    Some(Stencil {
        node: origin.node as usize,
        weights,
        offset: origin.distance * -h,
        inverse_inertia: D::Vector::from_fn(|a| inverse_inertia[a]),
    })
}

/// The stencil of a particle at `x` ([`locate`] then [`stencil_at`]), or `None` outside the
/// grid.
#[inline(always)]
pub fn stencil<D: Dim>(lattice: &Lattice<D>, x: D::Vector) -> Option<Stencil<D>> {
    let (origin, _) = locate(lattice, x)?;
    stencil_at(lattice, &origin)
}

impl<D: Dim> Stencil<D> {
    /// Calls `visit(index, weight, o)` for each node of the stencil, `o` its offset in nodes
    /// from the first along each axis, the first axis fastest.
    #[inline(always)]
    pub fn for_each_node(
        &self,
        strides: &[usize; 3],
        mut visit: impl FnMut(usize, f64, [usize; 3]),
    ) {
        let layers = if D::N == 3 { 3 } else { 1 };
        for oz in 0..layers {
            let wz = self.weights[2][oz];
            for oy in 0..3 {
                let wyz = self.weights[1][oy] * wz;
                let row = self.node + oz * strides[2] + oy * strides[1];
                for ox in 0..3 {
                    visit(row + ox, self.weights[0][ox] * wyz, [ox, oy, oz]);
                }
            }
        }
    }
}

/// What one particle gives its nodes: `N (m, q + A (x_I − x_p))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParticleShare<D: Dim> {
    /// Mass.
    pub mass: f64,
    /// Momentum after the step's forces, `m v + Δt (m b + f_ext)`.
    pub momentum: D::Vector,
    /// The affine momentum, `m C_p − Δt (1 − D) V σ D_p⁻¹`.
    pub affine: D::Matrix,
}

/// Mass and momentum summed on one node.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NodeSum<D: Dim> {
    /// `Σ N m`.
    pub mass: f64,
    /// `Σ N (q + A (x_I − x_p))`.
    pub momentum: D::Vector,
}

impl<D: Dim> Default for NodeSum<D> {
    fn default() -> Self {
        Self {
            mass: 0.0,
            momentum: D::Vector::ZERO,
        }
    }
}

/// Adds one particle's share to the nodes of its stencil; `nodes` starts at held node `start`.
#[inline(always)]
pub fn scatter_particle<D: Dim>(
    nodes: &mut [NodeSum<D>],
    start: usize,
    (stencil, lattice): (&Stencil<D>, &Lattice<D>),
    share: &ParticleShare<D>,
) {
    let h = lattice.spacing;
    // q + A (x_I − x_p) = (q + A (x_first − x_p)) + (A h) o: the column steps are added as
    // the loops advance.
    let origin = share.momentum + share.affine * stencil.offset;
    let step = |a: usize| share.affine.col(a) * h;
    let strides = &lattice.strides;
    let layers = if D::N == 3 { 3 } else { 1 };
    let mut layer = origin;
    for oz in 0..layers {
        let wz = stencil.weights[2][oz];
        let mut line = layer;
        for oy in 0..3 {
            let wyz = stencil.weights[1][oy] * wz;
            let row = stencil.node + oz * strides[2] + oy * strides[1] - start;
            let mut momentum = line;
            for (node, wx) in nodes[row..row + 3].iter_mut().zip(stencil.weights[0]) {
                let w = wx * wyz;
                node.mass += w * share.mass;
                node.momentum += momentum * w;
                momentum += step(0);
            }
            line += step(1);
        }
        if D::N == 3 {
            layer += step(2);
        }
    }
}

/// Scatters every particle of `order` into `nodes` (one per held node, zeroed here):
/// `add(p, nodes, start)` adds particle `p` to the nodes from held node `start` on. The even
/// slabs run in parallel, then the odd ones, so each node sums in one fixed order. Each slab's
/// loop runs [`vectorised`]: mark `add` `#[inline(always)]` so it is compiled into it.
pub fn scatter_slabs<D: Dim>(
    nodes: &mut [NodeSum<D>],
    order: &SlabOrder,
    row_len: usize,
    add: impl Fn(u32, &mut [NodeSum<D>], usize) + Sync,
) {
    nodes.par_iter_mut().for_each(|n| *n = NodeSum::default());
    let chunk = 2 * SLAB_ROWS * row_len;
    for colour in 0..2 {
        let start = (colour * SLAB_ROWS * row_len).min(nodes.len());
        nodes[start..]
            .par_chunks_mut(chunk.max(1))
            .enumerate()
            .for_each(|(j, piece)| {
                let slab = 2 * j + colour;
                if slab >= order.slabs() {
                    return;
                }
                let first = start + j * chunk;
                vectorised(
                    #[inline(always)]
                    || {
                        for &p in order.slab(slab) {
                            add(p, piece, first);
                        }
                    },
                );
            });
    }
}

/// What the grid gives a particle: `v_p = Σ N v̄_I` and `C_p = Σ N v̄_I ⊗ (x_I − x_p) D_p⁻¹`.
#[inline(always)]
pub fn gather_particle<D: Dim>(
    velocity: impl Fn(usize) -> D::Vector,
    (stencil, lattice): (&Stencil<D>, &Lattice<D>),
) -> (D::Vector, D::Matrix) {
    let mut v = D::Vector::ZERO;
    // Σ N v̄ o_a per axis: with x_I − x_p = offset + h o, B's column a is
    // Σ N v̄ (offset_a + h o_a) = offset_a v + h Σ N v̄ o_a.
    let mut moments = [D::Vector::ZERO; 3];
    let strides = &lattice.strides;
    let layers = if D::N == 3 { 3 } else { 1 };
    // The offsets are taken as f64 constants (`OFFSETS`): an unsigned conversion is an
    // instruction sequence.
    for (oz, z) in OFFSETS.iter().enumerate().take(layers) {
        let wz = stencil.weights[2][oz];
        for (oy, y) in OFFSETS.iter().enumerate() {
            let wyz = stencil.weights[1][oy] * wz;
            let row = stencil.node + oz * strides[2] + oy * strides[1];
            let [w0, w1, w2] = stencil.weights[0];
            let (v1, v2) = (velocity(row + 1) * w1, velocity(row + 2) * w2);
            let line = velocity(row) * w0 + v1 + v2;
            let line_x = v1 + v2 * 2.0;
            v += line * wyz;
            moments[0] += line_x * wyz;
            moments[1] += line * (wyz * y);
            if D::N == 3 {
                moments[2] += line * (wyz * z);
            }
        }
    }
    let h = lattice.spacing;
    let c = D::Matrix::from_fn(|i, j| {
        (stencil.offset[j] * v[i] + h * moments[j][i]) * stencil.inverse_inertia[j]
    });
    (v, c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basis::bspline::{BsplineParams, spline_axes};
    use crate::basis::tensor::tensor_row;

    /// The on-the-fly weights are `basis/bspline`'s quadratic row, inside and within half a
    /// cell of either face.
    #[test]
    fn weights_match_the_bspline_basis_with_folded_faces() {
        let grid = Grid::<Two>::uniform(DVec2::new(-0.2, 0.1), 0.1, [6, 5]);
        let lattice = Lattice::of(&grid);
        let params = BsplineParams { order: 2 };
        for &(x, y) in &[
            (-0.2, 0.1),
            (-0.17, 0.12),
            (0.05, 0.33),
            (0.37, 0.58),
            (0.399_999, 0.599_999),
        ] {
            let x = DVec2::new(x, y);
            let s = stencil(&lattice, x).unwrap();
            let factors = spline_axes(&grid, x, &params);
            let mut weights = vec![(0.0, 0.0); lattice.node_count()];
            s.for_each_node(&lattice.strides, |i, w, _| weights[i].0 = w);
            for (i, n, _) in tensor_row::<Two>(&grid, &factors) {
                weights[i as usize].1 = n;
            }
            for (i, (ours, theirs)) in weights.iter().enumerate() {
                assert!((ours - theirs).abs() < 1e-14, "node {i} at {x:?}");
            }
        }
    }

    /// The gather gives an affine nodal field back exactly, `v` and `C = ∇v`, in 3D, inside
    /// the grid and within half a cell of its faces (on a face `C`'s column along the face's
    /// normal is 0: the folded row is one node's there).
    #[test]
    fn the_gather_reproduces_an_affine_field_in_3d() {
        let grid = Grid::<Three>::uniform(DVec3::new(0.1, -0.2, 0.0), 0.2, [5, 4, 6]);
        let lattice = Lattice::of(&grid);
        let v0 = DVec3::new(0.3, -1.0, 0.5);
        let g = DMat3::from_cols(
            DVec3::new(0.1, 0.4, -0.2),
            DVec3::new(-0.3, 0.2, 0.7),
            DVec3::new(0.5, -0.6, 0.05),
        );
        let field = |i: usize| v0 + g * grid.node_position(i);
        let points = [
            DVec3::new(0.55, 0.31, 0.47),
            DVec3::new(0.13, 0.55, 1.19),
            DVec3::new(1.08, -0.17, 0.01),
            DVec3::new(0.1, 0.0, grid.max().z),
        ];
        for x in points {
            let s = stencil(&lattice, x).unwrap();
            let (v, c) = gather_particle(field, (&s, &lattice));
            assert!((v - (v0 + g * x)).length() < 1e-13, "{x:?}: {v:?}");
            for j in 0..3 {
                let on_face = x[j] == grid.min[j] || x[j] == grid.max()[j];
                let expected = if on_face { DVec3::ZERO } else { g.col(j) };
                assert!(
                    (c.col(j) - expected).length() < 1e-12,
                    "{x:?} column {j}: {c:?}"
                );
            }
        }
    }

    /// On a rank's window of the grid, the stencil's nodes are the window's indices of the
    /// whole grid's nodes.
    #[test]
    fn a_window_numbers_the_stencil_as_the_grid_does() {
        let whole = Grid::<Two>::uniform(DVec2::ZERO, 0.5, [10, 8]);
        let window = whole.windowed(NodeWindow {
            first: [3, 2],
            counts: [5, 6],
        });
        let x = DVec2::new(2.4, 2.1);
        let s = stencil(&Lattice::of(&window), x).unwrap();
        let first = [
            ((x.x / 0.5) - 0.5).floor() as usize,
            ((x.y / 0.5) - 0.5).floor() as usize,
        ];
        assert_eq!(s.node, window.node_index(first));
        assert_eq!(locate(&Lattice::of(&window), x).unwrap().1, first[1] - 2);
        assert_eq!(s, stencil(&Lattice::of(&window), x).unwrap());
        let whole_stencil = stencil(&Lattice::of(&whole), x).unwrap();
        assert_eq!(s.weights, whole_stencil.weights);
        assert_eq!(s.offset, whole_stencil.offset);
    }

    /// The slab scatter gives every node the sums of a plain loop over the particles (to
    /// round-off: the order differs), and the same bits on one thread as on three.
    #[test]
    fn the_slab_scatter_sums_what_a_plain_loop_sums() {
        let grid = Grid::<Two>::uniform(DVec2::ZERO, 0.1, [12, 15]);
        let lattice = Lattice::of(&grid);
        let positions: Vec<DVec2> = (0..300)
            .map(|k| DVec2::new(0.004 * k as f64, 1.5 * ((k * 37) % 101) as f64 / 100.0))
            .collect();
        let share = |k: usize| ParticleShare::<Two> {
            mass: 1.0 + 0.01 * k as f64,
            momentum: DVec2::new(k as f64, -0.5),
            affine: DMat2::from_cols(DVec2::new(0.2, k as f64), DVec2::new(-1.0, 0.3)),
        };
        let rows: Vec<u32> = positions
            .iter()
            .map(|x| locate(&lattice, *x).unwrap().1 as u32)
            .collect();
        let mut order = SlabOrder::default();
        order.sort(&rows, lattice.rows().div_ceil(SLAB_ROWS));
        let slabbed = |threads: usize| {
            let mut nodes = vec![NodeSum::<Two>::default(); lattice.node_count()];
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                scatter_slabs(&mut nodes, &order, lattice.row_len(), |p, piece, start| {
                    let s = stencil(&lattice, positions[p as usize]).unwrap();
                    scatter_particle(piece, start, (&s, &lattice), &share(p as usize));
                })
            });
            nodes
        };
        let mut plain = vec![NodeSum::<Two>::default(); lattice.node_count()];
        for (k, x) in positions.iter().enumerate() {
            let s = stencil(&lattice, *x).unwrap();
            scatter_particle(&mut plain, 0, (&s, &lattice), &share(k));
        }
        let one = slabbed(1);
        assert_eq!(one, slabbed(3));
        for (a, b) in one.iter().zip(&plain) {
            assert!((a.mass - b.mass).abs() < 1e-12 * (1.0 + b.mass));
            assert!((a.momentum - b.momentum).length() < 1e-11 * (1.0 + b.momentum.length()));
        }
        let total: f64 = one.iter().map(|n| n.mass).sum();
        let expected: f64 = (0..300).map(|k| share(k).mass).sum();
        assert!((total - expected).abs() < 1e-10);
    }
}
