//! What the two paths of `basis/lme` share, the uniform grid's (`basis/lme`) and the graded
//! grid's (`lme_graded.rs`): the parameters, the state kept between steps (λ warm starts and
//! candidate lists, carried by checkpoints and across ranks), the node cloud, and the writing
//! of a solved row into the connectivity tables.
//!
//! - Stage: basis (not a registration itself).

use super::lme_kernel::LmeScratch;
use crate::spatial::Spatial;
use fractum_engine::prelude::*;
use rayon::prelude::*;
use serde::Deserialize;

/// Parameters of `basis/lme`.
#[derive(Resource, Deserialize, Clone, Copy, Debug, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct LmeParams {
    /// γ̂.
    pub gamma: f64,
    /// Support truncation tolerance.
    pub support_tolerance: f64,
    /// Newton tolerance relative to h.
    pub newton_tolerance: f64,
    /// Newton iteration cap.
    pub max_iterations: usize,
}

impl Default for LmeParams {
    fn default() -> Self {
        Self {
            gamma: 3.5,
            support_tolerance: 1e-6,
            newton_tolerance: 1e-12,
            max_iterations: 50,
        }
    }
}

/// Per-particle state kept between steps.
#[derive(Resource, Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct LmeState<D: Dim> {
    /// λ of every particle row from the last step (the Newton warm start).
    pub lambda: Vec<D::Vector>,
    /// `dλ/dx = 2βI − J⁻¹` at the last solution, to carry λ to the new position.
    pub lambda_slope: Vec<D::Matrix>,
    /// Where each particle was at its last solution.
    pub solved_at: Vec<D::Vector>,
    /// Where each particle was when its candidate list was built.
    pub anchors: Vec<D::Vector>,
    /// Nodes within radius + skin of the anchor, ascending.
    pub candidates: Vec<Vec<u32>>,
    /// On a graded grid, the radius each candidate list was built with.
    pub reach: Vec<f64>,
}

impl<D: Dim> Default for LmeState<D> {
    fn default() -> Self {
        Self {
            lambda: Vec::new(),
            lambda_slope: Vec::new(),
            solved_at: Vec::new(),
            anchors: Vec::new(),
            candidates: Vec::new(),
            reach: Vec::new(),
        }
    }
}

impl<D: Dim> LmeState<D> {
    /// Sizes the state for `particles` rows; a changed count starts every row afresh (no warm
    /// start, an empty candidate list).
    pub fn resize(&mut self, particles: usize) {
        if self.lambda.len() != particles {
            self.lambda = vec![D::Vector::ZERO; particles];
            self.lambda_slope = vec![D::Matrix::ZERO; particles];
            self.solved_at = vec![D::Vector::ZERO; particles];
            self.anchors = vec![D::Vector::splat(f64::INFINITY); particles];
            self.candidates = vec![Vec::new(); particles];
            self.reach = vec![0.0; particles];
        }
    }
}

/// Node positions with a kd-tree for radius searches.
pub struct NodeCloud<D: Spatial> {
    tree: D::Tree,
    positions: Vec<D::Vector>,
}

impl<D: Spatial> NodeCloud<D> {
    /// Builds the tree over `positions` (node index = position in the slice).
    pub fn new(positions: Vec<D::Vector>) -> Self {
        Self {
            tree: D::tree(&positions),
            positions,
        }
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// True when there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Indices of the nodes within `radius` of `x`, ascending.
    pub fn within(&self, x: D::Vector, radius: f64) -> Vec<u32> {
        let mut found = Vec::new();
        D::within(&self.tree, x, radius, &mut found);
        found.sort_unstable();
        found
    }

    /// Position of node `i`.
    pub fn position(&self, i: u32) -> D::Vector {
        self.positions[i as usize]
    }

    /// Every node's position, by node index.
    pub fn positions(&self) -> &[D::Vector] {
        &self.positions
    }
}

/// Per-thread buffers for a particle's row (`basis::lme::particle_row`).
#[derive(Clone, Debug)]
pub struct RowScratch<D: Dim> {
    pub(super) support: Vec<u32>,
    pub(super) positions: Vec<D::Vector>,
    pub(super) lme: LmeScratch,
}

impl<D: Dim> Default for RowScratch<D> {
    fn default() -> Self {
        Self {
            support: Vec::new(),
            positions: Vec::new(),
            lme: LmeScratch::default(),
        }
    }
}

/// What the solve of one particle gives beside its row: λ and `J⁻¹`.
pub type Solved<D> = (<D as Dim>::Vector, <D as Dim>::Matrix);

/// The row slices of one particle in the connectivity tables: nodes, `N`, `∇N`.
pub type RowSlices<'a, D> = (&'a mut [u32], &'a mut [f64], &'a mut [<D as Dim>::Vector]);

/// Writes the solved support of `scratch` into `row`: each node, its `N` and the gradient
/// `gradient(x_I, N_I)` (in the coordinates the nodes were given in).
pub fn write_row<D: Dim>(
    scratch: &RowScratch<D>,
    row: RowSlices<'_, D>,
    gradient: impl Fn(D::Vector, f64) -> D::Vector,
) {
    let (nodes, weights, gradients) = row;
    write_nodes_and_values(scratch, nodes, weights);
    for ((g, &xi), &n) in gradients
        .iter_mut()
        .zip(&scratch.positions)
        .zip(&scratch.lme.values)
    {
        *g = gradient(xi, n);
    }
}

/// Writes the solved support of `scratch`: each node and its `N`.
pub fn write_nodes_and_values<D: Dim>(
    scratch: &RowScratch<D>,
    nodes: &mut [u32],
    weights: &mut [f64],
) {
    let support = scratch.support.iter().zip(&scratch.lme.values);
    for ((node, weight), (&i, &n)) in nodes.iter_mut().zip(weights.iter_mut()).zip(support) {
        (*node, *weight) = (i, n);
    }
}

/// Keeps every particle's λ, `dλ/dx = 2βI − J⁻¹` and position for the next step's warm start,
/// or the first particle whose solve failed, with the reason. In parallel, from the basis
/// system's buffer of solutions (kept from step to step): a serial pass over them, and before
/// that a serial gather of the rows' blocks into a new buffer, were the largest serial sections
/// of the LME step at a million particles (`benches/serial_share.py`).
pub fn keep_solutions<D: Dim>(
    solved: &[Result<Solved<D>, String>],
    beta: f64,
    positions: &[Position<D>],
    lambda: &mut [D::Vector],
    lambda_slope: &mut [D::Matrix],
    solved_at: &mut [D::Vector],
) -> Result<(), (usize, String)> {
    if let Some(p) = solved.par_iter().position_first(Result::is_err) {
        let message = solved[p].as_ref().err().cloned().unwrap_or_default();
        return Err((p, message));
    }
    let identity_2beta = D::Matrix::IDENTITY * (2.0 * beta);
    solved
        .par_iter()
        .zip(lambda.par_iter_mut())
        .zip(lambda_slope.par_iter_mut())
        .zip(solved_at.par_iter_mut())
        .zip(positions.par_iter())
        .for_each(|((((result, l), slope), at), x)| {
            if let Ok((solution, j_inverse)) = result {
                *l = *solution;
                *slope = identity_2beta - *j_inverse;
                *at = x.0;
            }
        });
    Ok(())
}

/// Why a row of `count` nodes cannot be solved, when it has fewer than the `D + 1` a particle
/// needs around it (the LME weights exist only inside the convex hull of the nodes): none, when
/// it has enough. Without this check a row of no node solves trivially to no weights, and the
/// particle silently stops moving.
pub fn too_few_nodes<D: Dim>(count: usize) -> Option<String> {
    (count <= D::N).then(|| {
        format!(
            "only {count} grid node(s) lie within the LME support, and a particle needs at least              {} around it (it must lie inside their convex hull): the support is too small for              the grid (lower `gamma` or `support_tolerance`), or the particle is outside the grid",
            D::N + 1
        )
    })
}

/// The message of a solve that did not converge.
pub fn non_convergence(f: &super::lme_kernel::LmeFailure) -> String {
    format!(
        "LME shape functions did not converge: |r| = {:e} after {} Newton iterations over {} \
         nodes (a particle at the edge of the node cloud, or too few nodes in the support; \
         try a smaller gamma)",
        f.residual, f.iterations, f.nodes
    )
}

// The checkpoint key of this system's state (stable across builds).
impl<D: Dim> fractum_engine::checkpoint::State for LmeState<D> {
    const KEY: &'static str = "lme/state";
}

/// One row of [`LmeState`] as it goes to another rank with its particle: the warm start (λ,
/// its slope and where it was solved), `None` before the first solve.
pub type LmeRow<D> = Option<(<D as Dim>::Vector, <D as Dim>::Matrix, <D as Dim>::Vector)>;

// In a distributed run each particle's warm start goes with it, so that its Newton iterations
// are the single process's; the candidate lists are rebuilt.
impl<D: Dim> fractum_engine::checkpoint::RowState for LmeState<D> {
    type Row = LmeRow<D>;

    fn row(&self, row: usize) -> LmeRow<D> {
        Some((
            *self.lambda.get(row)?,
            *self.lambda_slope.get(row)?,
            *self.solved_at.get(row)?,
        ))
    }

    fn set_rows(&mut self, rows: Vec<LmeRow<D>>) {
        if rows.iter().all(Option::is_none) {
            // Nothing solved yet: the first step sizes the state.
            *self = Self::default();
            return;
        }
        let n = rows.len();
        let unsolved = (D::Vector::ZERO, D::Matrix::ZERO, D::Vector::ZERO);
        (self.lambda, self.lambda_slope, self.solved_at) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for (lambda, slope, at) in rows.into_iter().map(|r| r.unwrap_or(unsolved)) {
            self.lambda.push(lambda);
            self.lambda_slope.push(slope);
            self.solved_at.push(at);
        }
        // An anchor at infinity is stale: every candidate list is built afresh.
        self.anchors = vec![D::Vector::splat(f64::INFINITY); n];
        self.candidates = vec![Vec::new(); n];
        self.reach = vec![0.0; n];
    }
}
