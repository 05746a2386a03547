//! Rows of tensor-product shape functions on a uniform grid: along each axis a few consecutive
//! nodes with their one-dimensional weight and slope, and the row their product makes. Shared
//! by `basis/gimp` and `basis/bspline`, which differ only in the one-dimensional function.

use fractum_engine::prelude::*;

/// Most nodes along one axis of a row (a cubic B-spline's four).
pub const MAX_AXIS_NODES: usize = 4;

/// Along each axis, the nodes with a positive weight (consecutive): lattice index, weight `S`
/// and slope `dS/dr`.
#[derive(Clone, Copy, Debug)]
pub struct AxisFactors {
    nodes: [[(usize, f64, f64); MAX_AXIS_NODES]; 3],
    count: [usize; 3],
}

impl AxisFactors {
    /// Factors with no node on any axis, to be filled by [`AxisFactors::add`].
    pub fn empty() -> Self {
        Self {
            nodes: [[(0usize, 0.0, 0.0); MAX_AXIS_NODES]; 3],
            count: [0; 3],
        }
    }

    /// Adds `weight` and `slope` to lattice index `node` along `axis`: to its entry if it has
    /// one, else as a new one, kept in lattice order. Returns `false`, leaving the factors as
    /// they were, when the axis already has [`MAX_AXIS_NODES`] other nodes.
    pub fn add(&mut self, axis: usize, node: usize, weight: f64, slope: f64) -> bool {
        let count = self.count[axis];
        let entries = &mut self.nodes[axis];
        if let Some(entry) = entries[..count].iter_mut().find(|e| e.0 == node) {
            entry.1 += weight;
            entry.2 += slope;
            return true;
        }
        if count == MAX_AXIS_NODES {
            return false;
        }
        let at = entries[..count].partition_point(|e| e.0 < node);
        entries.copy_within(at..count, at + 1);
        entries[at] = (node, weight, slope);
        self.count[axis] += 1;
        true
    }

    /// Appends `weight` and `slope` at lattice index `node` along `axis`, which must come after
    /// the axis's other nodes (and be the fourth at most): [`AxisFactors::add`] for nodes known
    /// to arrive once each, in order.
    pub fn push(&mut self, axis: usize, node: usize, weight: f64, slope: f64) {
        let count = self.count[axis];
        debug_assert!(
            count < MAX_AXIS_NODES && (count == 0 || self.nodes[axis][count - 1].0 < node)
        );
        self.nodes[axis][count] = (node, weight, slope);
        self.count[axis] = count + 1;
    }

    /// Entries of the row: the product of the per-axis counts.
    pub fn width(&self, dimensions: usize) -> usize {
        self.count[..dimensions].iter().product()
    }
}

/// The per-axis factors of the row of a particle at `x` on uniform `grid`, from the
/// one-dimensional function `shape(r) = (S, dS/dr)` of the signed distance `r` from a node,
/// which is zero from `reach` cells on; or the first axis along which the support leaves the
/// grid.
pub fn axis_factors<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    reach: f64,
    shape: impl Fn(f64) -> (f64, f64),
) -> Result<AxisFactors, usize> {
    let h = grid.spacing;
    let nodes = grid.nodes_per_axis();
    let mut factors = AxisFactors::empty();
    let candidates = ceil_index(2.0 * reach) as usize + 1;
    for a in 0..D::N {
        let s = (x[a] - grid.min[a]) / h;
        let low = ceil_index(s - reach);
        for k in 0..candidates {
            let node = low + k as isize;
            let r = x[a] - (grid.min[a] + node as f64 * h);
            let (weight, slope) = shape(r);
            if weight > 0.0 && factors.count[a] < MAX_AXIS_NODES {
                if node < 0 || node as usize >= nodes[a] {
                    return Err(a);
                }
                factors.nodes[a][factors.count[a]] = (node as usize, weight, slope);
                factors.count[a] += 1;
            }
        }
        if factors.count[a] == 0 {
            break;
        }
    }
    Ok(factors)
}

/// `value.ceil() as isize`, without the call to `ceil` that the baseline x86-64 target makes
/// of it (no rounding instruction): the truncation, one up where it fell below `value`. The
/// same for every `f64`: NaN gives 0 and the casts saturate as `as` does.
#[inline]
pub fn ceil_index(value: f64) -> isize {
    let truncated = value as isize;
    if (truncated as f64) < value {
        truncated.saturating_add(1)
    } else {
        truncated
    }
}

/// [`axis_factors`] as runs of consecutive nodes, one per axis ([`AxisRun::UNIT`] past the
/// dimension), written into `runs`: the same nodes and values, found the same way (a
/// positive `shape` holds on one interval of nodes, so the nodes it keeps are consecutive).
/// `Err` with the first axis along which the support leaves the grid; an axis with no node
/// ends the search, as there (the row is then empty).
pub fn axis_runs<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    reach: f64,
    shape: impl Fn(f64) -> (f64, f64),
    runs: &mut [AxisRun; 3],
) -> Result<(), usize> {
    let h = grid.spacing;
    let nodes = grid.nodes_per_axis();
    let candidates = ceil_index(2.0 * reach) as usize + 1;
    for (a, run) in runs.iter_mut().enumerate().take(D::N) {
        let s = (x[a] - grid.min[a]) / h;
        let low = ceil_index(s - reach);
        run.count = 0;
        for k in 0..candidates {
            let node = low + k as isize;
            let r = x[a] - (grid.min[a] + node as f64 * h);
            let (weight, slope) = shape(r);
            if weight > 0.0 && run.count < MAX_AXIS_NODES {
                if node < 0 || node as usize >= nodes[a] {
                    return Err(a);
                }
                run.push(node as usize, weight, slope);
            }
        }
        if run.count == 0 {
            break;
        }
    }
    Ok(())
}

/// The entries of the row of `runs`: the product of their counts.
pub fn runs_width(runs: &[AxisRun; 3]) -> usize {
    runs.iter().map(|run| run.count).product()
}

/// Writes the tensor product of `factors` (first axis fastest, lattice order) into a row of
/// `factors.width()` entries: node, weight, gradient.
pub fn write_tensor_row<D: Dim>(
    grid: &Grid<D>,
    factors: &AxisFactors,
    (nodes, weights, gradients): (&mut [u32], &mut [f64], &mut [D::Vector]),
) {
    if factors.width(D::N) == 0 {
        return;
    }
    let axis = &factors.nodes;
    let mut digit = [0usize; 3];
    for k in 0.. {
        weights[k] = (0..D::N).fold(1.0, |w, a| w * axis[a][digit[a]].1);
        gradients[k] = D::Vector::from_fn(|a| {
            (0..D::N).fold(1.0, |g, b| {
                let (_, s, ds) = axis[b][digit[b]];
                g * if b == a { ds } else { s }
            })
        });
        nodes[k] = grid.node_index(D::Cell::from_fn(|a| axis[a][digit[a]].0)) as u32;
        let mut a = 0;
        loop {
            digit[a] += 1;
            if digit[a] < factors.count[a] {
                break;
            }
            digit[a] = 0;
            a += 1;
            if a == D::N {
                return;
            }
        }
    }
}

/// One axis of a row whose nodes along it are consecutive lattice indices (no node folded
/// onto another): the first node, how many, and each one's weight `S` and slope `dS/dr`.
/// An axis a dimension lacks is one node of weight 1 and slope 0 ([`AxisRun::UNIT`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisRun {
    /// Lattice index of the first node.
    pub first: usize,
    /// Nodes in the run, at most [`MAX_AXIS_NODES`].
    pub count: usize,
    /// Each node's weight.
    pub weight: [f64; MAX_AXIS_NODES],
    /// Each node's slope.
    pub slope: [f64; MAX_AXIS_NODES],
}

impl AxisRun {
    /// The run of an axis the grid does not have: a factor of one.
    pub const UNIT: Self = Self {
        first: 0,
        count: 1,
        weight: [1.0; MAX_AXIS_NODES],
        slope: [0.0; MAX_AXIS_NODES],
    };

    /// Appends the next node's weight and slope; `false` (nothing added) when the run is full.
    #[inline]
    pub fn push(&mut self, node: usize, weight: f64, slope: f64) -> bool {
        if self.count == MAX_AXIS_NODES {
            return false;
        }
        if self.count == 0 {
            self.first = node;
        }
        self.weight[self.count] = weight;
        self.slope[self.count] = slope;
        self.count += 1;
        true
    }
}

/// Writes the tensor product of `runs` (one per axis; [`AxisRun::UNIT`] past the dimension)
/// into a row of `Π count` entries, the entries, values and order [`write_tensor_row`] gives
/// for the same factors, to the bit: weights and gradient components are the same products
/// taken in the same order (a missing axis's factor is an exact 1), and node indices step by
/// the held lattice's strides from the box's first node. `false`, with nothing written, when
/// a corner of the box is not among the nodes this world holds (the caller's general path
/// then reports it).
pub fn write_box_row<D: Dim>(
    grid: &Grid<D>,
    runs: &[AxisRun; 3],
    (nodes, weights, gradients): (&mut [u32], &mut [f64], &mut [D::Vector]),
) -> bool {
    if runs.iter().any(|run| run.count == 0) {
        return true;
    }
    let first = D::Cell::from_fn(|a| runs[a].first);
    let last = D::Cell::from_fn(|a| runs[a].first + runs[a].count - 1);
    let (Some(base), Some(_)) = (grid.held_node_index(first), grid.held_node_index(last)) else {
        return false;
    };
    let counts = grid
        .window
        .as_ref()
        .map_or(grid.nodes_per_axis(), |w| w.counts);
    let stride_y = if D::N > 1 { counts[0] } else { 0 };
    let stride_z = if D::N > 2 { counts[0] * counts[1] } else { 0 };
    let [x, y, z] = runs;
    let mut k = 0;
    for c in 0..z.count {
        for b in 0..y.count {
            let row_base = base + b * stride_y + c * stride_z;
            let (sy, sz, dy, dz) = (y.weight[b], z.weight[c], y.slope[b], z.slope[c]);
            for a in 0..x.count {
                let (sx, dx) = (x.weight[a], x.slope[a]);
                weights[k] = sx * sy * sz;
                gradients[k] = D::Vector::from_fn(|axis| match axis {
                    0 => dx * sy * sz,
                    1 => sx * dy * sz,
                    _ => sx * sy * dz,
                });
                nodes[k] = (row_base + a) as u32;
                k += 1;
            }
        }
    }
    true
}

/// One particle's connectivity row: `(node, weight, gradient)` per node.
pub type Row<D> = Vec<(u32, f64, <D as Dim>::Vector)>;

/// The row of `factors` as a vector (an allocating convenience for tests and tools).
pub fn tensor_row<D: Dim>(grid: &Grid<D>, factors: &AxisFactors) -> Row<D> {
    let width = factors.width(D::N);
    let mut nodes = vec![0; width];
    let mut weights = vec![0.0; width];
    let mut gradients = vec![D::Vector::ZERO; width];
    write_tensor_row(grid, factors, (&mut nodes, &mut weights, &mut gradients));
    nodes
        .into_iter()
        .zip(weights)
        .zip(gradients)
        .map(|((i, w), g)| (i, w, g))
        .collect()
}

/// Test check that the row `write_box_row` writes from `runs` is `expected` to the bit: nodes,
/// weights and every gradient component (`at` names the particle in a failure).
#[cfg(test)]
pub fn assert_box_row_is<D: Dim>(
    grid: &Grid<D>,
    runs: &[AxisRun; 3],
    expected: &Row<D>,
    at: &dyn std::fmt::Debug,
) {
    let width = expected.len();
    assert_eq!(runs_width(runs), width, "{at:?}");
    let (mut nodes, mut weights) = (vec![0; width], vec![0.0; width]);
    let mut gradients = vec![D::Vector::ZERO; width];
    let row = (&mut nodes[..], &mut weights[..], &mut gradients[..]);
    assert!(write_box_row(grid, runs, row), "{at:?}");
    for (k, &(node, weight, gradient)) in expected.iter().enumerate() {
        assert_eq!(nodes[k], node, "{at:?}");
        assert_eq!(weights[k].to_bits(), weight.to_bits(), "{at:?}");
        for a in 0..D::N {
            assert_eq!(gradients[k][a].to_bits(), gradient[a].to_bits(), "{at:?}");
        }
    }
}

/// Test check of a row at `x`: partition of unity, linear reproduction (to `reproduction`),
/// `Σ ∇N = 0`, `Σ x_I ⊗ ∇N_I = I`, and no weight negative (a row may keep a node whose weight
/// is zero at `x` for its gradient, as a boundary-folded spline's on the grid's face).
#[cfg(test)]
pub fn assert_consistent_row<D: Dim>(
    grid: &Grid<D>,
    x: D::Vector,
    row: &Row<D>,
    reproduction: f64,
) {
    let sum: f64 = row.iter().map(|e| e.1).sum();
    let first: D::Vector = row
        .iter()
        .map(|e| grid.node_position(e.0 as usize) * e.1)
        .sum();
    let grad_sum: D::Vector = row.iter().map(|e| e.2).sum();
    let jacobian = row.iter().fold(D::Matrix::ZERO, |acc, e| {
        acc + D::Matrix::outer(grid.node_position(e.0 as usize), e.2)
    });
    assert!((sum - 1.0).abs() < 1e-14, "{sum}");
    assert!((first - x).length() < reproduction);
    assert!(grad_sum.length() < 1e-12);
    assert!((jacobian - D::Matrix::IDENTITY).max_abs() < 1e-12);
    assert!(row.iter().all(|e| e.1 >= 0.0), "{row:?}");
}
