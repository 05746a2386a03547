//! `basis/lme` on a graded (rectilinear) grid: each particle's problem solved in the
//! coordinates scaled by the local node spacing along each axis, `ξ = (x_I − x) / s(x)`, with
//! `β = γ̂` there (see `basis/lme`'s header). An affine map, so partition of unity, linear
//! reproduction and `Σ x_I ⊗ ∇N_I = I` hold exactly, and the Newton problem is that of a unit
//! grid whatever the grading.
//!
//! - Stage: basis (the graded path of `basis/lme`; not a registration itself).

use super::lme_kernel::{LmeSettings, lme_gradient, lme_solve, support_radius};
use super::lme_rows::{
    LmeParams, LmeState, NodeCloud, RowScratch, RowSlices, Solved, keep_solutions, non_convergence,
    too_few_nodes, write_row,
};
use crate::spatial::Spatial;
use fractum_engine::prelude::*;
use rayon::prelude::*;

/// Whether `xi` is in the support of a particle at `x` on a graded grid: within `radius` in the
/// coordinates scaled by the local spacing `scale` (one per axis).
fn in_scaled_support<V: VectorOps>(x: V, xi: V, scale: V, radius2: f64) -> bool {
    ((xi - x) / scale).length_squared() <= radius2
}

/// Refreshes the candidate lists of particles that moved too far from where their list was
/// built, on a graded grid: every node of a particle's support lies within `needed` of it, and
/// its list holds every node within `reach` of its anchor.
fn refresh_graded_candidates<D: Spatial>(
    cloud: &NodeCloud<D>,
    positions: &[Position<D>],
    scales: &[D::Vector],
    radii: &[f64],
    (anchors, candidates, reach): (&mut [D::Vector], &mut [Vec<u32>], &mut [f64]),
) {
    anchors
        .par_iter_mut()
        .zip(candidates.par_iter_mut())
        .zip(reach.par_iter_mut())
        .zip(positions.par_iter().zip(scales).zip(radii))
        .for_each(|(((anchor, list), reach), ((x, scale), radius))| {
            let needed = radius * (0..D::N).map(|a| scale[a]).fold(0.0, f64::max);
            if needed + (x.0 - *anchor).length() > *reach {
                *reach = 1.25 * needed;
                *list = cloud.within(x.0, *reach);
                *anchor = x.0;
            }
        });
}

/// One particle's row on a graded grid: the problem solved in the coordinates scaled by the
/// local spacing `scale`, over the candidates within the scaled radius (`support`: the nodes,
/// the candidates, the squared radius).
fn graded_row<D: Spatial>(
    (cloud, candidates, radius2): (&NodeCloud<D>, &[u32], f64),
    x: D::Vector,
    scale: D::Vector,
    settings: &LmeSettings,
    guess: D::Vector,
    scratch: &mut RowScratch<D>,
    row: RowSlices<'_, D>,
) -> Result<Solved<D>, String> {
    scratch.support.clear();
    scratch.positions.clear();
    for &i in candidates {
        let xi = cloud.position(i);
        if in_scaled_support(x, xi, scale, radius2) {
            scratch.support.push(i);
            scratch.positions.push((xi - x) / scale);
        }
    }
    if let Some(message) = too_few_nodes::<D>(scratch.positions.len()) {
        return Err(message);
    }
    let (lambda, j_inverse, _) = lme_solve::<D>(
        D::Vector::ZERO,
        &scratch.positions,
        settings,
        guess,
        &mut scratch.lme,
    )
    .map_err(|f| non_convergence(&f))?;
    write_row::<D>(scratch, row, |xi, n| {
        lme_gradient::<D>(D::Vector::ZERO, xi, n, j_inverse) / scale
    });
    Ok((lambda, j_inverse))
}

/// The rows of every particle on a graded grid, with the locality scaled to the grid around
/// each particle: in the coordinates `ξ = (x_I − x) / s(x)`, `s` the local node spacing along
/// each axis (`Grid::local_spacing`, continuous in `x`), the particle solves the LME problem
/// of a unit grid, `β = γ̂`; its `N_I` are the same in both coordinates and `∂N/∂x_a =
/// (∂N/∂ξ_a) / s_a`. This is `β = γ̂ / h_local²` made anisotropic where a rectilinear cell
/// is, and keeps every consistency condition exactly (ξ is an affine map of x). Returns the
/// first particle whose solve failed, with the reason.
pub(super) fn graded_rows<D: Spatial>(
    grid: &Grid<D>,
    params: &LmeParams,
    cloud: &NodeCloud<D>,
    positions: &[Position<D>],
    state: &mut LmeState<D>,
    (connectivity, solutions): (&mut Connectivity<D>, &mut [Result<Solved<D>, String>]),
) -> Result<(), (usize, String)> {
    let settings = LmeSettings {
        beta: params.gamma,
        tolerance: params.newton_tolerance,
        length_scale: 1.0,
        max_iterations: params.max_iterations,
    };
    let radius = support_radius(settings.beta, params.support_tolerance);
    let scales: Vec<D::Vector> = positions
        .par_iter()
        .map(|x| grid.local_spacing(x.0))
        .collect();
    // Each particle's support reaches at least the corners of its cell: where a cell is much
    // wider than the local spacing (a coarse cell beside a fine one) and γ̂ is large, the
    // radius alone can leave the particle outside the hull of its support, where no LME
    // solution exists. Elsewhere the radius covers the cell and nothing changes.
    let radii: Vec<f64> = positions
        .par_iter()
        .zip(&scales)
        .map(|(x, scale)| radius.max(cell_reach(grid, x.0, *scale)))
        .collect();
    state.resize(positions.len());
    let LmeState {
        lambda,
        lambda_slope,
        solved_at,
        anchors,
        candidates,
        reach,
    } = state;
    let lists = (&mut anchors[..], &mut candidates[..], &mut reach[..]);
    refresh_graded_candidates(cloud, positions, &scales, &radii, lists);
    let (candidates, guesses) = (&*candidates, (&*lambda, &*lambda_slope, &*solved_at));
    connectivity.fill_rows_into(
        cloud.len(),
        |p| {
            let (x, scale, radius2) = (positions[p].0, scales[p], radii[p] * radii[p]);
            candidates[p]
                .iter()
                .filter(|&&i| in_scaled_support(x, cloud.position(i), scale, radius2))
                .count()
        },
        RowScratch::<D>::default,
        solutions,
        |scratch, p, nodes, weights, gradients| {
            let (x, scale, radius2) = (positions[p].0, scales[p], radii[p] * radii[p]);
            let guess = guesses.0[p] + guesses.1[p] * ((x - guesses.2[p]) / scale);
            let support = (cloud, &candidates[p][..], radius2);
            graded_row(
                support,
                x,
                scale,
                &settings,
                guess,
                scratch,
                (nodes, weights, gradients),
            )
        },
    );
    keep_solutions(
        solutions,
        settings.beta,
        positions,
        lambda,
        lambda_slope,
        solved_at,
    )
}

/// The scaled distance from `x` to the farthest corner of its cell (0 outside the grid), a
/// hair beyond it so the corners pass the support test.
fn cell_reach<D: Dim>(grid: &Grid<D>, x: D::Vector, scale: D::Vector) -> f64 {
    let far2: Option<f64> = (0..D::N)
        .map(|a| {
            let i = grid.axis_cell(a, x[a])?;
            let (lo, hi) = (grid.coordinate(a, i), grid.coordinate(a, i + 1));
            let far = (x[a] - lo).abs().max((hi - x[a]).abs()) / scale[a];
            Some(far * far)
        })
        .sum();
    far2.map_or(0.0, |d2| d2.sqrt() * (1.0 + 1e-9))
}
