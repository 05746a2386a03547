//! Local maximum-entropy (LME) approximants at one point: the pure numerical kernel behind
//! `basis/lme` (not a system; see `lme.rs`).
//!
//! Arroyo & Ortiz's LME shape functions, eigensoftening-lme-mpm.md §2.2, eqs. (6)–(10):
//! `N_I = exp(−β|x − x_I|² + λ·(x − x_I)) / Z(x, λ)` with `λ*` minimising `log Z` (eq. 7);
//! `r = ∂ log Z/∂λ = Σ N_I (x − x_I)` (eq. 10), `J = ∂r/∂λ` (eq. 9), and for constant β
//! `∇N_I = −N_I J⁻¹ (x − x_I)` (eq. 8).
//!
//! `log Z` is convex in λ, so Newton's method from a warm start converges in a few steps. When
//! it does not (irregular node sets, points near the hull of their nodes), a damped Newton
//! method with a backtracking line search restarts from λ = 0; if that also fails, the caller
//! gets an error rather than shape functions that are not a partition of unity.

use fractum_engine::dim::outer;
use fractum_engine::prelude::{Matrix, Vector};

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
pub struct LmeSolution {
    /// The Lagrange multiplier λ*.
    pub lambda: Vector,
    /// `N_I`, in the order of the nodes given.
    pub values: Vec<f64>,
    /// `∇N_I`, in the same order.
    pub gradients: Vec<Vector>,
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
}

/// `log Z`, `r` and `J` at one λ (the `N_I` are in a buffer beside it).
#[derive(Clone, Copy, Debug)]
struct Moments {
    log_z: f64,
    r: Vector,
    j: Matrix,
}

/// Evaluates the moments at `lambda`, writing `N_I` into `values`.
fn moments(
    x: Vector,
    nodes: &[Vector],
    beta: f64,
    lambda: Vector,
    values: &mut Vec<f64>,
) -> Moments {
    values.clear();
    // Exponents first, then shifted by the largest so that exp never overflows.
    values.extend(nodes.iter().map(|&xi| {
        let d = x - xi;
        -beta * d.length_squared() + lambda.dot(d)
    }));
    let largest = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let mut z = 0.0;
    for v in values.iter_mut() {
        *v = (*v - largest).exp();
        z += *v;
    }
    let mut r = Vector::ZERO;
    let mut second = Matrix::ZERO;
    for (v, &xi) in values.iter_mut().zip(nodes) {
        *v /= z;
        let d = x - xi;
        r += *v * d;
        second += outer(d, d) * *v;
    }
    Moments {
        log_z: z.ln() + largest,
        r,
        j: second - outer(r, r),
    }
}

/// The Newton step `−J⁻¹ r`, or `None` when J is singular or the step is not finite.
fn newton_step(m: &Moments) -> Option<Vector> {
    let det = m.j.determinant();
    if !(det.is_finite() && det > f64::MIN_POSITIVE) {
        return None;
    }
    let step = -(m.j.inverse() * m.r);
    step.is_finite().then_some(step)
}

struct Problem<'a> {
    x: Vector,
    nodes: &'a [Vector],
    settings: &'a LmeSettings,
}

impl Problem<'_> {
    fn goal(&self) -> f64 {
        self.settings.tolerance * self.settings.length_scale
    }

    /// Moments at `lambda` into the scratch's trial buffer.
    fn trial(&self, lambda: Vector, scratch: &mut LmeScratch) -> Moments {
        moments(
            self.x,
            self.nodes,
            self.settings.beta,
            lambda,
            &mut scratch.trial,
        )
    }

    /// Moments at `lambda` into the scratch's current buffer.
    fn current(&self, lambda: Vector, scratch: &mut LmeScratch) -> Moments {
        moments(
            self.x,
            self.nodes,
            self.settings.beta,
            lambda,
            &mut scratch.values,
        )
    }

    /// One more Newton step if it still shrinks `|r|`: at quadratic convergence it takes the
    /// residual from the tolerance to round-off, which the gradient identities need because
    /// they carry `J⁻¹ r` and J is small near a node at large γ̂.
    fn polish(&self, lambda: Vector, m: Moments, scratch: &mut LmeScratch) -> (Vector, Moments) {
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
    fn plain_newton(
        &self,
        start: Vector,
        scratch: &mut LmeScratch,
    ) -> Result<(Vector, Moments, usize), usize> {
        let mut lambda = start;
        for k in 0..self.settings.max_iterations {
            let m = self.current(lambda, scratch);
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
    fn damped_newton(&self, scratch: &mut LmeScratch) -> Result<(Vector, Moments, usize), f64> {
        let mut lambda = Vector::ZERO;
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
                let trial = self.trial(lambda + t * direction, scratch);
                // Sufficient decrease of log Z, or (once its changes drown in round-off near
                // the minimum) a halving of the gradient norm.
                let decreases = trial.log_z <= m.log_z + 1e-4 * t * slope;
                let closer = trial.r.length() <= 0.5 * m.r.length();
                if trial.log_z.is_finite() && (decreases || closer) {
                    lambda += t * direction;
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

/// Solves for λ at `x` over `nodes`, warm-started from `lambda_guess`. On success `scratch.values`
/// holds `N_I` and the result carries λ, `J⁻¹` and the iterations used.
pub fn lme_solve(
    x: Vector,
    nodes: &[Vector],
    settings: &LmeSettings,
    lambda_guess: Vector,
    scratch: &mut LmeScratch,
) -> Result<(Vector, Matrix, usize), LmeFailure> {
    let problem = Problem { x, nodes, settings };
    let (lambda, m, iterations) = match problem.plain_newton(lambda_guess, scratch) {
        Ok(found) => found,
        Err(spent) => problem
            .damped_newton(scratch)
            .map(|(lambda, m, k)| (lambda, m, k + spent))
            .map_err(|residual| LmeFailure {
                residual,
                iterations: spent + settings.max_iterations,
                nodes: nodes.len(),
            })?,
    };
    Ok((lambda, m.j.inverse(), iterations))
}

/// `∇N_I = −N_I J⁻¹ (x − x_I)` (eq. 8).
pub fn lme_gradient(x: Vector, node: Vector, value: f64, j_inverse: Matrix) -> Vector {
    -value * (j_inverse * (x - node))
}

/// LME shape functions at `x` over `nodes`, warm-started from `lambda_guess` (allocating
/// convenience over [`lme_solve`]).
pub fn lme_shape_functions(
    x: Vector,
    nodes: &[Vector],
    settings: &LmeSettings,
    lambda_guess: Vector,
) -> Result<LmeSolution, LmeFailure> {
    let mut scratch = LmeScratch::default();
    let (lambda, j_inverse, iterations) =
        lme_solve(x, nodes, settings, lambda_guess, &mut scratch)?;
    let gradients = scratch
        .values
        .iter()
        .zip(nodes)
        .map(|(&n, &xi)| lme_gradient(x, xi, n, j_inverse))
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

#[cfg(test)]
mod tests {
    use super::*;
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

    fn grid_nodes(coords: &[f64]) -> Vec<Vector> {
        coords
            .iter()
            .flat_map(|&y| coords.iter().map(move |&x| Vector::new(x, y)))
            .collect()
    }

    /// Width of the interval of `coords` that holds `t`.
    fn local_spacing(coords: &[f64], t: f64) -> f64 {
        coords
            .windows(2)
            .find(|w| t <= w[1])
            .map_or(1.0, |w| w[1] - w[0])
    }

    fn support(x: Vector, all: &[Vector], radius: f64) -> Vec<Vector> {
        all.iter()
            .copied()
            .filter(|xi| (x - *xi).length() <= radius)
            .collect()
    }

    fn check_consistency(x: Vector, nodes: &[Vector], s: &LmeSettings) {
        let sol = lme_shape_functions(x, nodes, s, Vector::ZERO).expect("converges");
        let unity: f64 = sol.values.iter().sum();
        let reproduced: Vector = sol.values.iter().zip(nodes).map(|(n, xi)| *n * *xi).sum();
        let gradient_sum: Vector = sol.gradients.iter().copied().sum();
        let jacobian = sol
            .gradients
            .iter()
            .zip(nodes)
            .fold(Matrix::ZERO, |acc, (g, xi)| acc + outer(*xi, *g));
        assert!((unity - 1.0).abs() < 1e-10, "partition of unity: {unity}");
        assert!(
            (reproduced - x).length() < 1e-10,
            "linear reproduction: {reproduced} vs {x}"
        );
        assert!(
            gradient_sum.length() < 1e-10 / s.length_scale,
            "Σ∇N = {gradient_sum}"
        );
        let identity_error = (jacobian - Matrix::IDENTITY)
            .to_cols_array()
            .iter()
            .map(|v| v.abs())
            .fold(0.0, f64::max);
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

    proptest! {
        #[test]
        fn consistent_on_a_uniform_grid(px in 0.0f64..1.0, py in 0.0f64..1.0, gamma in 0.8f64..6.0) {
            let h = 0.1;
            let nodes = grid_nodes(&coordinates(|_| h, 20));
            let x = Vector::new(0.5 + px * h, 0.7 + py * h);
            let s = settings(gamma, h);
            check_consistency(x, &support(x, &nodes, support_radius(s.beta, 1e-6)), &s);
        }

        #[test]
        fn consistent_on_a_graded_grid(px in 0.05f64..0.95, py in 0.05f64..0.95, gamma in 0.8f64..4.0) {
            // Spacing grows by 15% per node: 0.05 at the left/bottom, 0.43 at the right/top.
            let coords = coordinates(|i| 0.05 * 1.15f64.powi(i as i32), 16);
            let nodes = grid_nodes(&coords);
            let extent = coords[coords.len() - 1];
            let x = Vector::new(px * extent, py * extent);
            // β from the local spacing: the coarser of the two cells the point sits in.
            let local_h = local_spacing(&coords, x.x).max(local_spacing(&coords, x.y));
            let s = settings(gamma, local_h);
            check_consistency(x, &support(x, &nodes, support_radius(s.beta, 1e-6).max(1.5 * local_h)), &s);
        }
    }

    #[test]
    fn warm_start_converges_in_fewer_iterations() {
        let h = 0.1;
        let nodes = grid_nodes(&coordinates(|_| h, 20));
        let s = settings(2.0, h);
        let x = Vector::new(1.03, 0.98);
        let near = support(x, &nodes, support_radius(s.beta, 1e-6));
        let cold = lme_shape_functions(x, &near, &s, Vector::ZERO).unwrap();
        let warm = lme_shape_functions(x, &near, &s, cold.lambda).unwrap();
        assert!(warm.iterations < cold.iterations || cold.iterations == 0);
        assert_eq!(warm.iterations, 0);
    }

    #[test]
    fn a_point_outside_the_hull_of_its_nodes_is_a_reported_failure() {
        let nodes = [
            Vector::new(0.0, 0.0),
            Vector::new(1.0, 0.0),
            Vector::new(0.0, 1.0),
        ];
        let s = settings(2.0, 1.0);
        let failure =
            lme_shape_functions(Vector::new(2.0, 2.0), &nodes, &s, Vector::ZERO).unwrap_err();
        assert_eq!(failure.nodes, 3);
        assert!(failure.residual > 0.1);
    }

    #[test]
    fn large_gamma_tends_to_the_bilinear_interpolant_at_cell_centres() {
        let h = 1.0;
        let nodes = grid_nodes(&coordinates(|_| h, 4));
        let s = settings(30.0, h);
        let x = Vector::new(1.5, 1.5);
        let near = support(x, &nodes, 1.0);
        let sol = lme_shape_functions(x, &near, &s, Vector::ZERO).unwrap();
        for (n, xi) in sol.values.iter().zip(&near) {
            let expected = if (x - *xi).length() < 0.8 { 0.25 } else { 0.0 };
            assert!((n - expected).abs() < 1e-6, "{xi}: {n}");
        }
    }
}
