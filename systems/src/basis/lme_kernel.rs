//! Local maximum-entropy (LME) approximants at one point: the pure numerical kernel behind
//! `basis/lme` (not a system; see `lme.rs`).
//!
//! Arroyo & Ortiz's LME shape functions, eigensoftening-lme-mpm.md §2.2, eqs. (6)–(10):
//! `N_I = exp(−β|x − x_I|² + λ·(x − x_I)) / Z(x, λ)` with `λ*` minimising `log Z` (eq. 7);
//! `r = ∂ log Z/∂λ = Σ N_I (x − x_I)` (eq. 10), `J = ∂r/∂λ` (eq. 9), and for constant β
//! `∇N_I = −N_I J⁻¹ (x − x_I)` (eq. 8).
//!
//! `log Z` is convex in λ, so Newton's method from a warm start converges in a few steps.
//! When the warm start is already close (the last Newton step `δ = −J⁻¹ r` changes every `N_I`
//! by less than [`LINEARISE_BELOW`] relatively), the step is applied to the values to first
//! order instead of re-evaluating the exponentials: `∂N_I/∂λ = N_I (d_I − r)` with
//! `d_I = x − x_I`, so `N_I ← N_I (1 + δ·(d_I − r))`. The corrected values are a partition of
//! unity with `Σ N_I d_I = r + Jδ = 0` exactly (to round-off), they differ from the exact
//! approximants by the second-order term, below `LINEARISE_BELOW²` relatively, and `J` is
//! recomputed from them, so the gradient identities of eq. 8 hold to round-off as well. One
//! evaluation of the exponentials per point instead of three (Newton step, convergence check,
//! polish). When it does not (irregular node sets, points near the hull of their nodes), a damped Newton
//! method with a backtracking line search restarts from λ = 0; if that also fails, the caller
//! gets an error rather than shape functions that are not a partition of unity.
//!
//! The sums over the support nodes (`Z`, `r`, `J`, the first-order update) are in
//! `lme_lanes.rs`, four nodes at a time; [`lme_solve`] runs the whole solve through
//! [`vectorised`], so they are AVX2 instructions where the CPU has them, with the baseline's
//! bits.
//!
//! Generic over the dimension: λ, `r` are `d`-vectors and `J` is `d × d`.

use super::lme_lanes::{self as lanes, LaneMoments, RowOffsets};
use fractum_engine::connectivity::RowMap;
use fractum_engine::prelude::{Dim, MatrixOps, VectorOps};
use fractum_engine::vector_isa::vectorised;

/// Solver settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmeSettings {
    /// Thermalisation β = γ̂ / h² (1/m²).
    pub beta: f64,
    /// Converged when `|r| ≤ tolerance · length_scale`.
    pub tolerance: f64,
    /// Length scale for the tolerance (the nodal spacing h).
    pub length_scale: f64,
    /// Newton iterations allowed in each of the two attempts.
    pub max_iterations: usize,
}

/// Shape functions of one point.
#[derive(Clone, Debug, PartialEq)]
pub struct LmeSolution<D: Dim> {
    /// The Lagrange multiplier λ*.
    pub lambda: D::Vector,
    /// `N_I`, in the order of the nodes given.
    pub values: Vec<f64>,
    /// `∇N_I`, in the same order.
    pub gradients: Vec<D::Vector>,
    /// Newton iterations used (both attempts).
    pub iterations: usize,
}

/// Why no shape functions were produced.
#[derive(Clone, Debug, PartialEq)]
pub struct LmeFailure {
    /// Residual `|r|` reached.
    pub residual: f64,
    /// Iterations spent.
    pub iterations: usize,
    /// Number of nodes in the support.
    pub nodes: usize,
}

/// Reusable buffers for one solve (one per thread), so the hot loop does not allocate.
#[derive(Clone, Debug, Default)]
pub struct LmeScratch {
    /// `N_I` at the current λ; holds the result after a successful solve.
    pub values: Vec<f64>,
    trial: Vec<f64>,
    offsets: RowOffsets,
}

/// `Z` (as its scaled sum and the shift of the exponents), `r` and `J` at one λ (the `N_I` are
/// in a buffer beside it).
type Moments<D> = LaneMoments<D>;

/// `log Z(x, λ)` (eq. 7's objective), taken only by the damped method's line search (a
/// logarithm per solve the fast path does not need).
fn log_z<D: Dim>(m: &Moments<D>) -> f64 {
    m.scaled_z.ln() + m.largest
}

/// The Newton step `−J⁻¹ r`, or `None` when J is singular or the step is not finite.
#[inline(always)]
fn newton_step<D: Dim>(m: &Moments<D>) -> Option<D::Vector> {
    let det = m.j.determinant();
    if !(det.is_finite() && det > f64::MIN_POSITIVE) {
        return None;
    }
    let step = -(m.j.inverse() * m.r);
    step.is_finite().then_some(step)
}

/// One point's solve: the settings (the support's offsets are in the scratch).
struct Problem<'a, D: Dim> {
    settings: &'a LmeSettings,
    dimension: std::marker::PhantomData<D>,
}

impl<D: Dim> Problem<'_, D> {
    #[inline(always)]
    fn goal(&self) -> f64 {
        self.settings.tolerance * self.settings.length_scale
    }

    /// Moments at `lambda` into the scratch's trial buffer.
    #[inline(always)]
    fn trial(&self, lambda: D::Vector, scratch: &mut LmeScratch) -> Moments<D> {
        let beta = self.settings.beta;
        lanes::moments::<D>(&scratch.offsets, beta, lambda, &mut scratch.trial)
    }

    /// Moments at `lambda` into the scratch's current buffer.
    #[inline(always)]
    fn current(&self, lambda: D::Vector, scratch: &mut LmeScratch) -> Moments<D> {
        let beta = self.settings.beta;
        lanes::moments::<D>(&scratch.offsets, beta, lambda, &mut scratch.values)
    }

    /// One more Newton step if it still shrinks `|r|`: at quadratic convergence it takes the
    /// residual from the tolerance to round-off, which the gradient identities need because
    /// they carry `J⁻¹ r` and J is small near a node at large γ̂.
    #[inline(always)]
    fn polish(
        &self,
        lambda: D::Vector,
        m: Moments<D>,
        scratch: &mut LmeScratch,
    ) -> (D::Vector, Moments<D>) {
        let Some(step) = newton_step(&m) else {
            return (lambda, m);
        };
        let trial = self.trial(lambda + step, scratch);
        // NaN residuals compare false and keep the current λ.
        let better = trial.r.length() < m.r.length();
        if better {
            std::mem::swap(&mut scratch.values, &mut scratch.trial);
            (lambda + step, trial)
        } else {
            (lambda, m)
        }
    }

    /// Plain Newton from `start`; `Err(iterations)` when it does not converge.
    /// `first` are the moments at `start` when the caller has them (with `scratch.values`
    /// holding their values), so they are not evaluated twice.
    #[inline(always)]
    fn plain_newton(
        &self,
        start: D::Vector,
        mut first: Option<Moments<D>>,
        scratch: &mut LmeScratch,
    ) -> Result<(D::Vector, Moments<D>, usize), usize> {
        let mut lambda = start;
        for k in 0..self.settings.max_iterations {
            let m = match first.take() {
                Some(m) => m,
                None => self.current(lambda, scratch),
            };
            if m.r.length() <= self.goal() {
                let (lambda, m) = self.polish(lambda, m, scratch);
                return Ok((lambda, m, k));
            }
            lambda += newton_step(&m).ok_or(k)?;
        }
        Err(self.settings.max_iterations)
    }

    /// Damped Newton with Armijo backtracking on `log Z`, from λ = 0; steepest descent when J
    /// is singular. `Err(residual)` when it does not converge.
    #[inline(always)]
    fn damped_newton(
        &self,
        scratch: &mut LmeScratch,
    ) -> Result<(D::Vector, Moments<D>, usize), f64> {
        let mut lambda = D::Vector::ZERO;
        let mut m = self.current(lambda, scratch);
        for k in 0..self.settings.max_iterations {
            if m.r.length() <= self.goal() {
                let (lambda, m) = self.polish(lambda, m, scratch);
                return Ok((lambda, m, k));
            }
            let direction = newton_step(&m).unwrap_or(-m.r);
            let slope = m.r.dot(direction);
            let mut t = 1.0;
            loop {
                let trial = self.trial(lambda + direction * t, scratch);
                // Sufficient decrease of log Z, or (once its changes drown in round-off near
                // the minimum) a halving of the gradient norm.
                let (trial_log_z, log_z) = (log_z(&trial), log_z(&m));
                let decreases = trial_log_z <= log_z + 1e-4 * t * slope;
                let closer = trial.r.length() <= 0.5 * m.r.length();
                if trial_log_z.is_finite() && (decreases || closer) {
                    lambda += direction * t;
                    m = trial;
                    std::mem::swap(&mut scratch.values, &mut scratch.trial);
                    break;
                }
                t *= 0.5;
                if t < 1e-12 {
                    return Err(m.r.length());
                }
            }
        }
        if m.r.length() <= self.goal() {
            Ok((lambda, m, self.settings.max_iterations))
        } else {
            Err(m.r.length())
        }
    }
}

/// The relative change of the values under which the last Newton step is applied to them to
/// first order. Its second-order remainder, below the square of this (1e-8 relatively), stays
/// two orders under the support truncation (`support_tolerance`, 1e-6 by default), which
/// already bounds how exactly the approximants are represented.
pub const LINEARISE_BELOW: f64 = 1e-4;

/// What the fast path found.
enum FastPath<D: Dim> {
    /// λ and `J⁻¹`, with the corrected values in the scratch.
    Accepted(D::Vector, D::Matrix),
    /// The step is too large: the moments at the guess, its values still in the scratch.
    Declined(Moments<D>),
    /// `J` of the corrected values is singular; the scratch's values are no longer the guess's.
    Spoiled,
}

/// The fast path: the moments at `lambda_guess`, one Newton step applied to the values to first
/// order and `J` recomputed from them, unless the step would change some value by more than
/// [`LINEARISE_BELOW`] relatively.
#[inline(always)]
fn linearised<D: Dim>(
    problem: &Problem<D>,
    lambda_guess: D::Vector,
    scratch: &mut LmeScratch,
) -> FastPath<D> {
    let m = problem.current(lambda_guess, scratch);
    let Some(delta) = newton_step(&m) else {
        return FastPath::Declined(m);
    };
    // Each value's relative change `δ·(d_I − r)`, kept in the trial buffer (free on this path)
    // for the correction below.
    let largest = lanes::changes::<D>(&scratch.offsets, delta, m.r, &mut scratch.trial);
    if largest > LINEARISE_BELOW {
        return FastPath::Declined(m);
    }
    let corrected =
        lanes::apply_changes::<D>(&scratch.offsets, &scratch.trial, &mut scratch.values);
    let det = corrected.j.determinant();
    if det.is_finite() && det > f64::MIN_POSITIVE {
        FastPath::Accepted(lambda_guess + delta, corrected.j.inverse())
    } else {
        FastPath::Spoiled
    }
}

/// λ, `J⁻¹` and the Newton iterations used.
pub type Solution<D> = (<D as Dim>::Vector, <D as Dim>::Matrix, usize);

/// Solves for λ at `x` over `nodes`, warm-started from `lambda_guess`. On success `scratch.values`
/// holds `N_I` and the result carries λ, `J⁻¹` and the iterations used.
pub fn lme_solve<D: Dim>(
    x: D::Vector,
    nodes: &[D::Vector],
    settings: &LmeSettings,
    lambda_guess: D::Vector,
    scratch: &mut LmeScratch,
) -> Result<Solution<D>, LmeFailure> {
    scratch.offsets.fill::<D>(x, nodes);
    // The whole solve in the widest instructions (`lme_lanes.rs` says why the baseline's copy
    // gives the same bits).
    let solved = vectorised(
        #[inline(always)]
        || solve_from::<D>(settings, lambda_guess, scratch),
    );
    scratch.values.truncate(nodes.len());
    solved.map_err(|(residual, iterations)| LmeFailure {
        residual,
        iterations,
        nodes: nodes.len(),
    })
}

/// [`lme_solve`] over the offsets already in the scratch: the fast path, then plain Newton,
/// then damped Newton; `Err((residual, iterations))` when none converges.
#[inline(always)]
fn solve_from<D: Dim>(
    settings: &LmeSettings,
    lambda_guess: D::Vector,
    scratch: &mut LmeScratch,
) -> Result<Solution<D>, (f64, usize)> {
    let problem = Problem::<D> {
        settings,
        dimension: std::marker::PhantomData,
    };
    let first = match linearised(&problem, lambda_guess, scratch) {
        FastPath::Accepted(lambda, j_inverse) => return Ok((lambda, j_inverse, 0)),
        FastPath::Declined(m) => Some(m),
        FastPath::Spoiled => None,
    };
    let (lambda, m, iterations) = match problem.plain_newton(lambda_guess, first, scratch) {
        Ok(found) => found,
        Err(spent) => problem
            .damped_newton(scratch)
            .map(|(lambda, m, k)| (lambda, m, k + spent))
            .map_err(|residual| (residual, spent + settings.max_iterations))?,
    };
    Ok((lambda, m.j.inverse(), iterations))
}

/// The map of eq. (8) at `x`: `∇N_I = −N_I J⁻¹ (x − x_I)` for every node of the row
/// ([`RowMap::gradient`]).
pub fn lme_row_map<D: Dim>(x: D::Vector, j_inverse: D::Matrix) -> RowMap<D> {
    RowMap {
        matrix: j_inverse,
        point: x,
    }
}

/// `∇N_I = −N_I J⁻¹ (x − x_I)` (eq. 8).
pub fn lme_gradient<D: Dim>(
    x: D::Vector,
    node: D::Vector,
    value: f64,
    j_inverse: D::Matrix,
) -> D::Vector {
    lme_row_map::<D>(x, j_inverse).gradient(node, value)
}

/// LME shape functions at `x` over `nodes`, warm-started from `lambda_guess` (allocating
/// convenience over [`lme_solve`]).
pub fn lme_shape_functions<D: Dim>(
    x: D::Vector,
    nodes: &[D::Vector],
    settings: &LmeSettings,
    lambda_guess: D::Vector,
) -> Result<LmeSolution<D>, LmeFailure> {
    let mut scratch = LmeScratch::default();
    let (lambda, j_inverse, iterations) =
        lme_solve::<D>(x, nodes, settings, lambda_guess, &mut scratch)?;
    let gradients = scratch
        .values
        .iter()
        .zip(nodes)
        .map(|(&n, &xi)| lme_gradient::<D>(x, xi, n, j_inverse))
        .collect();
    Ok(LmeSolution {
        lambda,
        values: scratch.values,
        gradients,
        iterations,
    })
}

/// Search radius at which the Gaussian factor `exp(−β r²)` falls to `tolerance`.
pub fn support_radius(beta: f64, tolerance: f64) -> f64 {
    (-tolerance.ln() / beta).sqrt()
}

/// The largest locality γ̂ for which every particle of a uniform grid in `dimensions`
/// dimensions lies inside the convex hull of the nodes in its support (truncated at
/// `tolerance`), which the LME weights need. The hardest place is beside a node on a cell's
/// edge, half a cell from its ends: in the cell's own units it needs a node one cell across and
/// half a cell along each other axis, at √(1 + (d − 1)/4) (1 in 1D, √1.25 in 2D, √1.5 in 3D);
/// the support radius √(−ln tol / γ̂) ([`support_radius`] with β = γ̂) reaches it while
/// γ̂ ≤ −ln tol / (1 + (d − 1)/4).
pub fn largest_locality(dimensions: usize, tolerance: f64) -> f64 {
    -tolerance.ln() / (1.0 + (dimensions as f64 - 1.0) / 4.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the largest locality the support of a particle beside a node on a cell's edge still
    /// reaches a node across the cell (it lies inside its nodes' hull); a little more locality
    /// and it does not.
    #[test]
    fn the_largest_locality_keeps_an_edge_particle_inside_its_nodes() {
        let tolerance = 1e-6;
        for d in 1..=3usize {
            let largest = largest_locality(d, tolerance);
            // The particle at (ε, ½, ½, …) in cell units; the nearest node with a larger x.
            let epsilon: f64 = 1e-9;
            let across = ((1.0 - epsilon).powi(2) + (d - 1) as f64 * 0.25).sqrt();
            assert!(
                support_radius(largest * (1.0 - 1e-6), tolerance) >= across,
                "{d}D"
            );
            assert!(support_radius(largest * 1.01, tolerance) < across, "{d}D");
        }
        assert!((largest_locality(2, 1e-6) - 11.052).abs() < 1e-3);
        assert!((largest_locality(3, 1e-6) - 9.210).abs() < 1e-3);
    }
    use fractum_engine::dim::lattice_range;
    use fractum_engine::prelude::{DMat2, DVec2, DVec3, Lattice, Three, Two};
    use proptest::prelude::*;

    /// Node coordinates along one axis: 0, then steps of `spacing(i)`.
    fn coordinates(spacing: impl Fn(usize) -> f64, n: usize) -> Vec<f64> {
        (0..=n)
            .scan(0.0, |acc, i| {
                let here = *acc;
                *acc += spacing(i);
                Some(here)
            })
            .collect()
    }

    /// The tensor-product node set of `coords` along every axis.
    fn grid_nodes<D: Dim>(coords: &[f64]) -> Vec<D::Vector> {
        lattice_range(D::Cell::default(), D::Cell::from_fn(|_| coords.len()))
            .map(|ijk| D::Vector::from_fn(|a| coords[ijk[a]]))
            .collect()
    }

    /// Width of the interval of `coords` that holds `t`.
    fn local_spacing(coords: &[f64], t: f64) -> f64 {
        coords
            .windows(2)
            .find(|w| t <= w[1])
            .map_or(1.0, |w| w[1] - w[0])
    }

    fn support<D: Dim>(x: D::Vector, all: &[D::Vector], radius: f64) -> Vec<D::Vector> {
        all.iter()
            .copied()
            .filter(|xi| (x - *xi).length() <= radius)
            .collect()
    }

    fn check_consistency<D: Dim>(x: D::Vector, nodes: &[D::Vector], s: &LmeSettings) {
        let sol = lme_shape_functions::<D>(x, nodes, s, D::Vector::ZERO).expect("converges");
        let unity: f64 = sol.values.iter().sum();
        let reproduced: D::Vector = sol.values.iter().zip(nodes).map(|(n, xi)| *xi * *n).sum();
        let gradient_sum: D::Vector = sol.gradients.iter().copied().sum();
        let jacobian = sol
            .gradients
            .iter()
            .zip(nodes)
            .fold(D::Matrix::ZERO, |acc, (g, xi)| {
                acc + D::Matrix::outer(*xi, *g)
            });
        assert!((unity - 1.0).abs() < 1e-10, "partition of unity: {unity}");
        assert!(
            (reproduced - x).length() < 1e-10,
            "linear reproduction: {reproduced:?} vs {x:?}"
        );
        assert!(
            gradient_sum.length() < 1e-10 / s.length_scale,
            "Σ∇N = {gradient_sum:?}"
        );
        let identity_error = (jacobian - D::Matrix::IDENTITY).max_abs();
        assert!(
            identity_error < 1e-10,
            "Σ x_I ⊗ ∇N_I − I = {identity_error}"
        );
        assert!(sol.values.iter().all(|n| *n >= 0.0));
    }

    fn settings(gamma: f64, h: f64) -> LmeSettings {
        LmeSettings {
            beta: gamma / (h * h),
            tolerance: 1e-12,
            length_scale: h,
            max_iterations: 50,
        }
    }

    /// A point `offset` (fractions of a cell) into the interior of a uniform grid of 20 cells.
    fn uniform_case<D: Dim>(offset: D::Vector, gamma: f64) {
        let h = 0.1;
        let nodes = grid_nodes::<D>(&coordinates(|_| h, 20));
        let x = D::Vector::splat(0.6) + offset * h;
        let s = settings(gamma, h);
        let near = support::<D>(x, &nodes, support_radius(s.beta, 1e-6));
        check_consistency::<D>(x, &near, &s);
    }

    /// A point at fractions `at` of a graded grid whose spacing grows by 15% per node.
    fn graded_case<D: Dim>(at: D::Vector, gamma: f64, cells: usize) {
        let coords = coordinates(|i| 0.05 * 1.15f64.powi(i as i32), cells);
        let nodes = grid_nodes::<D>(&coords);
        let x = at * coords[coords.len() - 1];
        // β from the local spacing: the coarsest of the cells the point sits in.
        let local_h = (0..D::N)
            .map(|a| local_spacing(&coords, x[a]))
            .fold(0.0, f64::max);
        let s = settings(gamma, local_h);
        let radius = support_radius(s.beta, 1e-6).max(1.5 * local_h);
        check_consistency::<D>(x, &support::<D>(x, &nodes, radius), &s);
    }

    proptest! {
        #[test]
        fn consistent_on_a_uniform_grid(px in 0.0f64..1.0, py in 0.0f64..1.0, gamma in 0.8f64..6.0) {
            uniform_case::<Two>(DVec2::new(px, py), gamma);
        }

        #[test]
        fn consistent_on_a_graded_grid(px in 0.05f64..0.95, py in 0.05f64..0.95, gamma in 0.8f64..4.0) {
            // Spacing from 0.05 at the left/bottom to 0.43 at the right/top.
            graded_case::<Two>(DVec2::new(px, py), gamma, 16);
        }

        #[test]
        fn consistent_on_a_uniform_grid_in_3d(px in 0.0f64..1.0, py in 0.0f64..1.0, pz in 0.0f64..1.0, gamma in 0.8f64..6.0) {
            uniform_case::<Three>(DVec3::new(px, py, pz), gamma);
        }

        #[test]
        fn consistent_on_a_graded_grid_in_3d(px in 0.05f64..0.95, py in 0.05f64..0.95, pz in 0.05f64..0.95, gamma in 0.8f64..4.0) {
            graded_case::<Three>(DVec3::new(px, py, pz), gamma, 12);
        }
    }

    #[test]
    fn warm_start_converges_in_fewer_iterations() {
        let h = 0.1;
        let nodes = grid_nodes::<Two>(&coordinates(|_| h, 20));
        let s = settings(2.0, h);
        let x = DVec2::new(1.03, 0.98);
        let near = support::<Two>(x, &nodes, support_radius(s.beta, 1e-6));
        let cold = lme_shape_functions::<Two>(x, &near, &s, DVec2::ZERO).unwrap();
        let warm = lme_shape_functions::<Two>(x, &near, &s, cold.lambda).unwrap();
        assert!(warm.iterations < cold.iterations || cold.iterations == 0);
        assert_eq!(warm.iterations, 0);
    }

    /// The one-evaluation path: from a guess carried to a moved point (as `basis/lme` makes
    /// it), the values agree with a full Newton solve to far below the support truncation,
    /// and the consistency identities hold to round-off.
    #[test]
    fn a_carried_guess_gives_the_converged_approximants_in_one_evaluation() {
        let h = 0.1;
        let nodes = grid_nodes::<Two>(&coordinates(|_| h, 20));
        let s = settings(3.5, h);
        let radius = support_radius(s.beta, 1e-6);
        let x = DVec2::new(1.03, 0.98);
        let mut scratch = LmeScratch::default();
        let near = support::<Two>(x, &nodes, radius);
        let (lambda, j_inverse, _) =
            lme_solve::<Two>(x, &near, &s, DVec2::ZERO, &mut scratch).expect("converges");
        let moved = x + DVec2::new(2e-4, -1e-4) * h;
        let carried = lambda + (DMat2::IDENTITY * (2.0 * s.beta) - j_inverse) * (moved - x);
        let fast = lme_shape_functions::<Two>(moved, &near, &s, carried).unwrap();
        assert_eq!(fast.iterations, 0);
        let full = lme_shape_functions::<Two>(moved, &near, &s, DVec2::ZERO).unwrap();
        assert!(full.iterations > 0);
        let largest = full.values.iter().copied().fold(0.0, f64::max);
        for (a, b) in fast.values.iter().zip(&full.values) {
            assert!((a - b).abs() < 1e-10 * largest, "{a} vs {b}");
        }
        let unity: f64 = fast.values.iter().sum();
        let reproduced: DVec2 = fast.values.iter().zip(&near).map(|(n, xi)| *xi * *n).sum();
        let jacobian = fast
            .gradients
            .iter()
            .zip(&near)
            .fold(DMat2::ZERO, |acc, (g, xi)| acc + DMat2::outer(*xi, *g));
        assert!((unity - 1.0).abs() < 1e-14);
        assert!((reproduced - moved).length() < 1e-14);
        assert!((jacobian - DMat2::IDENTITY).max_abs() < 1e-12);
    }

    #[test]
    fn a_point_outside_the_hull_of_its_nodes_is_a_reported_failure() {
        let nodes = [
            DVec2::new(0.0, 0.0),
            DVec2::new(1.0, 0.0),
            DVec2::new(0.0, 1.0),
        ];
        let s = settings(2.0, 1.0);
        let failure =
            lme_shape_functions::<Two>(DVec2::new(2.0, 2.0), &nodes, &s, DVec2::ZERO).unwrap_err();
        assert_eq!(failure.nodes, 3);
        assert!(failure.residual > 0.1);
        let nodes = [DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z];
        let failure =
            lme_shape_functions::<Three>(DVec3::splat(1.0), &nodes, &s, DVec3::ZERO).unwrap_err();
        assert_eq!(failure.nodes, 4);
    }

    /// At a cell centre, large γ̂ gives the multilinear interpolant: 1/2^d on the cell's corners.
    fn tends_to_multilinear<D: Dim>() {
        let h = 1.0;
        let nodes = grid_nodes::<D>(&coordinates(|_| h, 4));
        let s = settings(30.0, h);
        let x = D::Vector::splat(1.5);
        let near = support::<D>(x, &nodes, 1.0);
        let sol = lme_shape_functions::<D>(x, &near, &s, D::Vector::ZERO).unwrap();
        let corner = 1.0 / (1 << D::N) as f64;
        for (n, xi) in sol.values.iter().zip(&near) {
            let expected = if (x - *xi).length() < 0.9 {
                corner
            } else {
                0.0
            };
            assert!((n - expected).abs() < 1e-6, "{xi:?}: {n}");
        }
    }

    #[test]
    fn large_gamma_tends_to_the_multilinear_interpolant_at_cell_centres() {
        tends_to_multilinear::<Two>();
        tends_to_multilinear::<Three>();
    }
}
