//! `fractum bench`: particle-steps per second of the stock pipelines on a generated scene.
//!
//! The scene is a square (2D) or cubic (3D) elastic block filled with 2 particles per cell per
//! direction, vibrating in a sine velocity profile, on a grid with a margin of four cells; no
//! output is written. It is built in code with the scene builder. One warm-up step (cold LME
//! multipliers, first neighbour search) is excluded from the timing.

use fractum_engine::prelude::*;
use fractum_engine::registry::Registry;
use fractum_engine::scene::{Body, InitialVelocity, Output, Shape, Spec};
use fractum_engine::simulation::{End, TimeStep};
use std::fmt::Write as _;
use std::time::Instant;

/// A pipeline to benchmark; on the command line in kebab case (`linear-usl`, `dfg-contact`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchPipeline {
    /// `basis/linear` + update-stress-last + linear elasticity.
    LinearUsl,
    /// `basis/gimp` + update-stress-last + linear elasticity: the cost of GIMP's wider rows.
    GimpUsl,
    /// `basis/lme` (γ̂ = 3.5) + Newmark predictor-corrector + linear elasticity.
    LmeNewmark,
    /// `linear-usl` plus `neighbour/kdtree` and `damage/eigensoftening` (strength too high to
    /// crack): the cost of the every-step neighbour lists and damage update of a body below its
    /// strength, where eigensoftening's bound skips the non-local sums.
    KdtreeSoftening,
    /// As `kdtree-softening` with `neighbour/node_linked`.
    NodeLinkedSoftening,
    /// `basis/linear` + Newmark + linear elasticity, one velocity field: the baseline of
    /// `dfg-contact`.
    LinearNewmark,
    /// `linear-newmark` + `partition/dfg` (surface detection, so the block's surface layer is
    /// partitioned) + `contact/frictional` (μ = 0.3): the cost of the kernel damage field, its
    /// neighbour list, the field assignment and the contact stage.
    DfgContact,
}

impl BenchPipeline {
    /// Name used on the command line and in the table.
    pub fn name(self) -> &'static str {
        match self {
            BenchPipeline::LinearUsl => "linear+usl",
            BenchPipeline::GimpUsl => "gimp+usl",
            BenchPipeline::LmeNewmark => "lme+newmark",
            BenchPipeline::KdtreeSoftening => "linear+usl+kdtree+eigensoftening",
            BenchPipeline::NodeLinkedSoftening => "linear+usl+node_linked+eigensoftening",
            BenchPipeline::LinearNewmark => "linear+newmark",
            BenchPipeline::DfgContact => "linear+newmark+dfg+contact",
        }
    }

    /// The pipeline's systems, with their parameters.
    fn systems<D: Dim>(self, spec: Spec<D>) -> Spec<D> {
        let usl_on = |spec: Spec<D>, basis: &str| {
            spec.system(basis)
                .system("predictor/usl")
                .system("stress/linear_elastic")
                .system("advection/usl")
        };
        let usl = |spec: Spec<D>| usl_on(spec, "basis/linear");
        // Strength too high to crack: the lists are filtered every step, and the non-local sums
        // are skipped by eigensoftening's bound (BENCHMARKS.md gives the cost with them).
        let softening = |spec: Spec<D>, neighbour: &str| {
            usl(spec.system_with(neighbour, "(c_epsilon: 2.0)")).system_with(
                "damage/eigensoftening",
                "(tensile_strength: 1.0e12, fracture_energy: 100.0, band_width: 0.02)",
            )
        };
        let newmark = |spec: Spec<D>, partition: bool| {
            let spec = spec
                .system("basis/linear")
                .system("predictor/newmark")
                .system("stress/linear_elastic");
            let spec = if partition {
                spec.system_with("partition/dfg", "(surface: 0.8)")
                    .system_with("contact/frictional", "(friction: 0.3)")
            } else {
                spec
            };
            spec.system("corrector/newmark").system("advection/newmark")
        };
        match self {
            BenchPipeline::LinearNewmark => newmark(spec, false),
            BenchPipeline::DfgContact => newmark(spec, true),
            BenchPipeline::LinearUsl => usl(spec),
            BenchPipeline::GimpUsl => usl_on(spec, "basis/gimp"),
            BenchPipeline::LmeNewmark => spec
                .system_with("basis/lme", "(gamma: 3.5)")
                .system("predictor/newmark")
                .system("stress/linear_elastic")
                .system("corrector/newmark")
                .system("advection/newmark"),
            BenchPipeline::KdtreeSoftening => softening(spec, "neighbour/kdtree"),
            BenchPipeline::NodeLinkedSoftening => softening(spec, "neighbour/node_linked"),
        }
    }
}

/// The benchmark block with about `particles` particles in dimension `D`.
pub fn bench_spec<D: Dim>(pipeline: BenchPipeline, particles: usize) -> Spec<D> {
    let per_cell = (1usize << D::N) as f64;
    let cells = ((particles as f64 / per_cell)
        .powf(1.0 / D::N as f64)
        .round() as usize)
        .max(1);
    let h = 0.01;
    let margin = 4.0 * h;
    let side = cells as f64 * h;
    let grid = Grid::<D> {
        min: D::Vector::ZERO,
        spacing: h,
        cells: D::Cell::from_fn(|_| cells + 8),
        graded: None,
    };
    // Decreasing amplitudes along y (and z) so no two components are alike.
    let amplitude = D::Vector::from_fn(|a| 0.1 / (1 << a) as f64);
    let shape = match D::N {
        2 => Shape::Rectangle {
            min: DVec2::splat(margin),
            max: DVec2::splat(margin + side),
        },
        _ => Shape::Box {
            min: DVec3::splat(margin),
            max: DVec3::splat(margin + side),
        },
    };
    let spec = Spec::new(grid)
        .named("<bench>")
        .title(&format!(
            "benchmark block, {particles} particles, {}",
            pipeline.name()
        ))
        .time(TimeStep::Cfl(0.5), End::Steps(1_000_000))
        .material(Material::new("elastic", 1000.0, 1.0e6, 0.3))
        .body(Body::new(shape, "elastic").velocity(InitialVelocity::Sine {
            amplitude,
            axis: 0,
            wavelength: 2.0 * side,
            origin: margin,
        }))
        .output(Output {
            vtu_every: 0,
            csv_every: 0,
            ..Output::default()
        });
    pipeline.systems(spec)
}

/// One measurement.
#[derive(Clone, Debug)]
pub struct BenchResult {
    /// Pipeline.
    pub pipeline: BenchPipeline,
    /// Dimension of the block.
    pub dimension: Dimension,
    /// Particles in the scene.
    pub particles: usize,
    /// Threads.
    pub threads: usize,
    /// Timed steps.
    pub steps: u64,
    /// Wall seconds of the timed steps.
    pub seconds: f64,
}

impl BenchResult {
    /// Particle-steps per second.
    pub fn rate(&self) -> f64 {
        self.particles as f64 * self.steps as f64 / self.seconds.max(1e-12)
    }
}

/// What to measure.
#[derive(Clone, Copy, Debug)]
pub struct BenchCase {
    /// Pipeline.
    pub pipeline: BenchPipeline,
    /// Dimension of the block.
    pub dimension: Dimension,
    /// About this many particles.
    pub particles: usize,
    /// Threads.
    pub threads: usize,
    /// Timed steps.
    pub steps: u64,
}

/// Runs one measurement: build, one warm-up step, then `case.steps` timed steps.
pub fn measure(registry: &Registry, case: BenchCase) -> Result<BenchResult, String> {
    let built = with_dim!(case.dimension, D => {
        bench_spec::<D>(case.pipeline, case.particles).build(registry)
    })
    .map_err(|e| e.to_string())?;
    let mut sim = built.simulation;
    sim.set_threads(case.threads).map_err(|e| e.to_string())?;
    let count = sim.particle_count();
    sim.step().map_err(|e| e.to_string())?;
    let started = Instant::now();
    for _ in 0..case.steps {
        sim.step().map_err(|e| e.to_string())?;
    }
    Ok(BenchResult {
        pipeline: case.pipeline,
        dimension: case.dimension,
        particles: count,
        threads: case.threads,
        steps: case.steps,
        seconds: started.elapsed().as_secs_f64(),
    })
}

/// Default number of timed steps: about two million particle-steps, at least 5.
pub fn default_steps(particles: usize) -> u64 {
    (2_000_000 / particles.max(1)).max(5) as u64
}

/// Markdown table of results.
pub fn table(results: &[BenchResult]) -> String {
    let mut out = String::from(
        "| pipeline | dim | particles | threads | steps | wall (s) | particle-steps/s |\n| --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for r in results {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {} | {:.3} | {:.3e} |",
            r.pipeline.name(),
            match r.dimension {
                Dimension::Two => "2D",
                Dimension::Three => "3D",
            },
            r.particles,
            r.threads,
            r.steps,
            r.seconds,
            r.rate()
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generated_scenes_are_valid_and_have_the_requested_size() {
        let registry = fractum_systems::stock_registry();
        for pipeline in [
            BenchPipeline::LinearUsl,
            BenchPipeline::GimpUsl,
            BenchPipeline::LmeNewmark,
            BenchPipeline::KdtreeSoftening,
            BenchPipeline::NodeLinkedSoftening,
            BenchPipeline::LinearNewmark,
            BenchPipeline::DfgContact,
        ] {
            for (dimension, particles) in [(Dimension::Two, 400), (Dimension::Three, 512)] {
                let case = BenchCase {
                    pipeline,
                    dimension,
                    particles,
                    threads: 1,
                    steps: 2,
                };
                let result = measure(&registry, case).unwrap();
                assert_eq!(result.particles, particles);
                assert!(result.rate() > 0.0);
            }
        }
    }
}
