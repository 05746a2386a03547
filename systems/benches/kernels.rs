//! Criterion benchmarks of the hot numerical kernels, each alone and outside the ECS:
//! LME shape functions at one point, the bilinear row, a particle-to-grid scatter, a
//! grid-to-particle gather and the two stress updates. Run with `cargo bench -p fractum-systems`.

use criterion::{Criterion, criterion_group, criterion_main};
use fractum_engine::connectivity::Connectivity;
use fractum_engine::prelude::*;
use fractum_systems::basis::linear::bilinear_row;
use fractum_systems::basis::lme_kernel::{LmeScratch, LmeSettings, lme_solve, support_radius};
use fractum_systems::stress::linear_elastic::{ElasticState, update_elastic};
use fractum_systems::stress::neo_hookean::neo_hookean_stress_of;
use fractum_systems::transfer::interpolate;
use std::hint::black_box;

fn grid(cells: usize) -> Grid {
    Grid {
        min: Vector::ZERO,
        spacing: 1.0 / cells as f64,
        cells: [cells, cells],
    }
}

/// Particles at 2 × 2 per cell over the whole grid.
fn particles(g: &Grid) -> Vec<Vector> {
    let h = g.spacing;
    (0..2 * g.cells[1])
        .flat_map(|j| {
            (0..2 * g.cells[0])
                .map(move |i| Vector::new((i as f64 + 0.5) * h / 2.0, (j as f64 + 0.5) * h / 2.0))
        })
        .collect()
}

fn lme_point(c: &mut Criterion) {
    let g = grid(50);
    let h = g.spacing;
    let settings = LmeSettings {
        beta: 3.5 / (h * h),
        tolerance: 1e-12,
        length_scale: h,
        max_iterations: 50,
    };
    let x = Vector::new(0.503, 0.498);
    let radius = support_radius(settings.beta, 1e-6);
    let nodes: Vec<Vector> = (0..g.node_count())
        .map(|i| g.node_position(i))
        .filter(|n| (*n - x).length() <= radius)
        .collect();
    let mut scratch = LmeScratch::default();
    let (warm, _, _) = lme_solve(x, &nodes, &settings, Vector::ZERO, &mut scratch).unwrap();
    c.bench_function("lme_solve cold (13 nodes)", |b| {
        b.iter(|| lme_solve(black_box(x), &nodes, &settings, Vector::ZERO, &mut scratch).unwrap())
    });
    c.bench_function("lme_solve warm (13 nodes)", |b| {
        b.iter(|| {
            lme_solve(
                black_box(x + Vector::splat(1e-4 * h)),
                &nodes,
                &settings,
                warm,
                &mut scratch,
            )
            .unwrap()
        })
    });
}

fn transfers(c: &mut Criterion) {
    let g = grid(158); // about 100k particles
    let xs = particles(&g);
    let mut conn = Connectivity::default();
    c.bench_function("bilinear rows + transpose (100k particles)", |b| {
        b.iter(|| {
            conn.fill_fixed_width(xs.len(), 4, g.node_count(), |p, n, w, gr| {
                for (k, (node, weight, gradient)) in
                    bilinear_row(&g, xs[p]).unwrap().into_iter().enumerate()
                {
                    n[k] = node;
                    w[k] = weight;
                    gr[k] = gradient;
                }
            })
        })
    });
    let masses = vec![1.0; xs.len()];
    let mut node_mass = vec![0.0; g.node_count()];
    c.bench_function("scatter mass to nodes (100k particles)", |b| {
        b.iter(|| conn.scatter_to_nodes(&mut node_mass, |e, p| conn.weights[e] * masses[p]))
    });
    let accelerations =
        vec![NodeAcceleration([Vector::new(1.0, 2.0), Vector::ZERO]); g.node_count()];
    let velocities = vec![NodeVelocity([Vector::new(0.5, 0.1), Vector::ZERO]); g.node_count()];
    c.bench_function("gather to particles (100k particles)", |b| {
        b.iter(|| {
            (0..xs.len())
                .map(|p| interpolate(&conn, &accelerations, &velocities, p).0.x)
                .sum::<f64>()
        })
    });
}

fn stress(c: &mut Criterion) {
    let state = ElasticState {
        stress: SymTensor::ZERO,
        strain: SymTensor::ZERO,
        deformation_gradient: Matrix::IDENTITY,
        volume: 1.0,
        energy_density: 0.0,
    };
    let l = Matrix::from_cols(Vector::new(0.1, 0.02), Vector::new(-0.03, 0.05));
    c.bench_function("linear elastic update (one particle)", |b| {
        b.iter(|| update_elastic(black_box(&state), l, 1e-3, (40.0, 40.0), 1.0))
    });
    let f = Matrix::from_cols(Vector::new(1.01, 0.02), Vector::new(-0.03, 0.99));
    c.bench_function("neo-Hookean stress (one particle)", |b| {
        b.iter(|| neo_hookean_stress_of(black_box(f), 40.0, 40.0))
    });
}

// The macro generates an undocumented function.
#[allow(missing_docs)]
mod group {
    use super::*;
    criterion_group!(benches, lme_point, transfers, stress);
}
use group::benches;
criterion_main!(benches);
