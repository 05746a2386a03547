//! `fractum bench`: particle-steps per second of the stock pipelines on a generated scene.
//!
//! The scene is a square elastic block filled with 2 × 2 particles per cell, vibrating in a
//! sine velocity profile, on a grid with a margin of four cells; no output is written. One
//! warm-up step (cold LME multipliers, first neighbour search) is excluded from the timing.

use fractum_engine::registry::Registry;
use fractum_engine::scene::{SceneFile, build_simulation};
use std::fmt::Write as _;
use std::time::Instant;

/// A pipeline to benchmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchPipeline {
    /// `basis/linear` + update-stress-last + linear elasticity.
    LinearUsl,
    /// `basis/lme` (γ̂ = 3.5) + Newmark predictor-corrector + linear elasticity.
    LmeNewmark,
    /// `linear+usl` plus `neighbour/kdtree` and `damage/eigensoftening` (strength too high to
    /// crack, so every step evaluates the non-local stress): the neighbourhood and damage cost.
    KdtreeSoftening,
    /// As `KdtreeSoftening` with `neighbour/node_linked`.
    NodeLinkedSoftening,
}

impl BenchPipeline {
    /// Name used on the command line and in the table.
    pub fn name(self) -> &'static str {
        match self {
            BenchPipeline::LinearUsl => "linear+usl",
            BenchPipeline::LmeNewmark => "lme+newmark",
            BenchPipeline::KdtreeSoftening => "linear+usl+kdtree+eigensoftening",
            BenchPipeline::NodeLinkedSoftening => "linear+usl+node_linked+eigensoftening",
        }
    }

    fn entries(self) -> String {
        // Linear + USL with a neighbour builder and eigensoftening whose strength is too high
        // to crack, so every step evaluates the non-local stress of every particle.
        let softening = |neighbour: &str| {
            format!(
                r#"(system: "{neighbour}", params: (c_epsilon: 2.0)), (system: "basis/linear"),
                   (system: "predictor/usl"), (system: "stress/linear_elastic"),
                   (system: "damage/eigensoftening", params: (tensile_strength: 1.0e12,
                       fracture_energy: 100.0, band_width: 0.02)),
                   (system: "advection/usl")"#
            )
        };
        match self {
            BenchPipeline::LinearUsl => r#"(system: "basis/linear"), (system: "predictor/usl"),
                   (system: "stress/linear_elastic"), (system: "advection/usl")"#
                .to_string(),
            BenchPipeline::LmeNewmark => {
                r#"(system: "basis/lme", params: (gamma: 3.5)), (system: "predictor/newmark"),
                   (system: "stress/linear_elastic"), (system: "corrector/newmark"),
                   (system: "advection/newmark")"#
                    .to_string()
            }
            BenchPipeline::KdtreeSoftening => softening("neighbour/kdtree"),
            BenchPipeline::NodeLinkedSoftening => softening("neighbour/node_linked"),
        }
    }
}

/// The benchmark scene with about `particles` particles.
pub fn bench_scene(pipeline: BenchPipeline, particles: usize) -> String {
    let cells = ((particles as f64 / 4.0).sqrt().round() as usize).max(1);
    let h = 0.01;
    let margin = 4.0 * h;
    let side = cells as f64 * h;
    format!(
        r#"(
    title: "benchmark block, {particles} particles, {name}",
    time: (step: Cfl(0.5), end: Steps(1000000)),
    grid: (min: (0.0, 0.0), max: ({g}, {g}), spacing: {h}),
    materials: {{ "elastic": (density: 1000.0, youngs_modulus: 1.0e6, poisson_ratio: 0.3) }},
    bodies: [(
        shape: Rectangle(min: ({m}, {m}), max: ({e}, {e})),
        material: "elastic",
        particles_per_cell: 2,
        velocity: Sine(amplitude: (0.1, 0.05), axis: X, wavelength: {w}, origin: {m}),
    )],
    output: (vtu_every: 0, csv_every: 0),
    pipeline: [{entries}],
)"#,
        name = pipeline.name(),
        g = side + 2.0 * margin,
        m = margin,
        e = margin + side,
        w = 2.0 * side,
        entries = pipeline.entries(),
    )
}

/// One measurement.
#[derive(Clone, Debug)]
pub struct BenchResult {
    /// Pipeline.
    pub pipeline: BenchPipeline,
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

/// Runs one measurement: build, one warm-up step, then `steps` timed steps.
pub fn measure(
    registry: &Registry,
    pipeline: BenchPipeline,
    particles: usize,
    threads: usize,
    steps: u64,
) -> Result<BenchResult, String> {
    let file =
        SceneFile::parse("<bench>", bench_scene(pipeline, particles)).map_err(|e| e.to_string())?;
    let mut built = build_simulation(&file, registry).map_err(|e| e.to_string())?;
    let sim = &mut built.simulation;
    sim.set_threads(threads).map_err(|e| e.to_string())?;
    let count = sim.particle_count();
    sim.step().map_err(|e| e.to_string())?;
    let started = Instant::now();
    for _ in 0..steps {
        sim.step().map_err(|e| e.to_string())?;
    }
    Ok(BenchResult {
        pipeline,
        particles: count,
        threads,
        steps,
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
        "| pipeline | particles | threads | steps | wall (s) | particle-steps/s |\n| --- | --- | --- | --- | --- | --- |\n",
    );
    for r in results {
        let _ = writeln!(
            out,
            "| {} | {} | {} | {} | {:.3} | {:.3e} |",
            r.pipeline.name(),
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
            BenchPipeline::LmeNewmark,
            BenchPipeline::KdtreeSoftening,
            BenchPipeline::NodeLinkedSoftening,
        ] {
            let result = measure(&registry, pipeline, 400, 1, 2).unwrap();
            assert_eq!(result.particles, 400);
            assert!(result.rate() > 0.0);
        }
    }
}
