//! Criterion benchmarks of the hot numerical kernels, each alone and outside the ECS, in 2D
//! and 3D: LME shape functions at one point, the multilinear rows, a particle-to-grid scatter, a
//! grid-to-particle gather, the two stress updates and 3×3 principal values. Run with
//! `cargo bench -p fractum-systems --features bench`.

use criterion::{Criterion, criterion_group, criterion_main};
use fractum_engine::connectivity::Connectivity;
use fractum_engine::dim::lattice_range;
use fractum_engine::prelude::*;
use fractum_systems::basis::linear::{fill_multilinear_row, nodes_per_particle};
use fractum_systems::basis::lme_kernel::{LmeScratch, LmeSettings, lme_solve, support_radius};
use fractum_systems::stress::linear_elastic::{ElasticState, update_elastic};
use fractum_systems::stress::neo_hookean::neo_hookean_stress_of;
use fractum_systems::transfer::interpolate;
use std::hint::black_box;

fn grid<D: Dim>(cells: usize) -> Grid<D> {
    Grid {
        min: D::Vector::ZERO,
        spacing: 1.0 / cells as f64,
        cells: D::Cell::from_fn(|_| cells),
        graded: None,
        window: None,
    }
}

/// Particles at 2 per cell per direction over the whole grid.
fn particles<D: Dim>(g: &Grid<D>) -> Vec<D::Vector> {
    let h = g.spacing;
    let counts = D::Cell::from_fn(|a| 2 * g.cells[a]);
    lattice_range(D::Cell::default(), counts)
        .map(|k| D::Vector::from_fn(|a| (k[a] as f64 + 0.5) * h / 2.0))
        .collect()
}

fn lme_point<D: Dim>(c: &mut Criterion, cells: usize) {
    let g = grid::<D>(cells);
    let h = g.spacing;
    let settings = LmeSettings {
        beta: 3.5 / (h * h),
        tolerance: 1e-12,
        length_scale: h,
        max_iterations: 50,
    };
    let x = D::Vector::from_fn(|a| 0.503 - 0.005 * a as f64);
    let radius = support_radius(settings.beta, 1e-6);
    let nodes: Vec<D::Vector> = (0..g.node_count())
        .map(|i| g.node_position(i))
        .filter(|n| (*n - x).length() <= radius)
        .collect();
    let mut scratch = LmeScratch::default();
    let (warm, j_inverse, _) =
        lme_solve::<D>(x, &nodes, &settings, D::Vector::ZERO, &mut scratch).unwrap();
    // The guess `basis/lme` makes after a move Δx: λ + (2βI − J⁻¹) Δx.
    let moved = x + D::Vector::splat(1e-4 * h);
    let carried = warm + (D::Matrix::IDENTITY * (2.0 * settings.beta) - j_inverse) * (moved - x);
    let label = format!("{}D, {} nodes", D::N, nodes.len());
    c.bench_function(&format!("lme_solve cold ({label})"), |b| {
        b.iter(|| {
            lme_solve::<D>(
                black_box(x),
                &nodes,
                &settings,
                D::Vector::ZERO,
                &mut scratch,
            )
            .unwrap()
        })
    });
    c.bench_function(&format!("lme_solve warm ({label})"), |b| {
        b.iter(|| {
            lme_solve::<D>(
                black_box(x + D::Vector::splat(1e-4 * h)),
                &nodes,
                &settings,
                warm,
                &mut scratch,
            )
            .unwrap()
        })
    });
    c.bench_function(&format!("lme_solve carried ({label})"), |b| {
        b.iter(|| {
            lme_solve::<D>(black_box(moved), &nodes, &settings, carried, &mut scratch).unwrap()
        })
    });
}

fn transfers<D: Dim>(c: &mut Criterion, cells: usize) {
    let g = grid::<D>(cells);
    let xs = particles(&g);
    let label = format!("{}D, {}k particles", D::N, xs.len() / 1000);
    let mut conn = Connectivity::<D>::default();
    c.bench_function(&format!("multilinear rows + transpose ({label})"), |b| {
        b.iter(|| {
            conn.fill_fixed_width(
                xs.len(),
                nodes_per_particle::<D>(),
                g.node_count(),
                |p, n, w, gr| {
                    fill_multilinear_row(&g, xs[p], n, w, gr);
                },
            )
        })
    });
    let masses = vec![1.0; xs.len()];
    let mut node_mass = vec![0.0; g.node_count()];
    c.bench_function(&format!("scatter mass to nodes ({label})"), |b| {
        b.iter(|| conn.scatter_to_nodes(&mut node_mass, |e, p| conn.weights[e] * masses[p]))
    });
    let v = D::Vector::from_fn(|a| 0.5 - 0.2 * a as f64);
    let accelerations = vec![NodeAcceleration::<D>(slots(&[v * 2.0])); g.node_count()];
    let velocities = vec![NodeVelocity::<D>(slots(&[v])); g.node_count()];
    c.bench_function(&format!("gather to particles ({label})"), |b| {
        b.iter(|| {
            (0..xs.len())
                .map(|p| interpolate(&conn, &accelerations, &velocities, p).0[0])
                .sum::<f64>()
        })
    });
}

fn stress<D: Dim>(c: &mut Criterion) {
    let state = ElasticState::<D> {
        stress: D::Sym::ZERO,
        strain: D::Sym::ZERO,
        deformation_gradient: D::Matrix::IDENTITY,
        volume: 1.0,
        energy_density: 0.0,
    };
    let grad =
        |i: usize, j: usize| [[0.1, -0.03, 0.01], [0.02, 0.05, 0.0], [-0.02, 0.01, 0.04]][i][j];
    let l = D::Matrix::from_fn(grad);
    c.bench_function(
        &format!("linear elastic update ({}D, one particle)", D::N),
        |b| {
            b.iter(|| {
                update_elastic::<D>(
                    black_box(&state),
                    black_box(l),
                    black_box(1e-3),
                    black_box((40.0, 40.0)),
                    black_box(1.0),
                )
            })
        },
    );
    let f = D::Matrix::IDENTITY + D::Matrix::from_fn(grad) * 0.1;
    c.bench_function(
        &format!("neo-Hookean stress ({}D, one particle)", D::N),
        |b| b.iter(|| neo_hookean_stress_of::<D>(black_box(f), black_box(40.0), black_box(40.0))),
    );
    let s = D::Sym::from_fn(|i, j| grad(i, j) + grad(j, i));
    c.bench_function(&format!("largest principal value ({}D)", D::N), |b| {
        b.iter(|| black_box(s).largest_principal())
    });
}

fn two_dimensions(c: &mut Criterion) {
    lme_point::<Two>(c, 50);
    transfers::<Two>(c, 158); // about 100k particles
    stress::<Two>(c);
}

fn three_dimensions(c: &mut Criterion) {
    lme_point::<Three>(c, 20);
    transfers::<Three>(c, 23); // about 100k particles
    stress::<Three>(c);
}

// The macro generates an undocumented function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, two_dimensions, three_dimensions);
}
use group::benches;
criterion_main!(benches);
