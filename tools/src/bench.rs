//! `fractum bench`: particle-steps per second of the stock pipelines on a generated scene.
//!
//! The scene is a square (2D) or cubic (3D) elastic block filled with 2 particles per cell per
//! direction, vibrating in a sine velocity profile, on a grid with a margin of four cells; no
//! output is written. It is built in code with the scene builder. One warm-up step (cold LME
//! multipliers, first neighbour search) is excluded from the timing.
//!
//! With `--profile` each measurement also gives the wall time of every stage per step
//! ([`fractum_engine::profile`]), the bytes a particle-step moves as counted from the data each
//! system reads and writes ([`fractum_engine::traffic`]), and the memory bandwidth of a
//! STREAM-style triad at the same thread count ([`triad_bandwidth`]): the rate as a fraction of
//! what the bandwidth allows (the roofline), and, where one and several threads were measured,
//! the serial fraction of the step (Karp–Flatt) and the speedup it predicts at 16 threads.

use fractum_engine::prelude::*;
use fractum_engine::profile::StageClock;
use fractum_engine::registry::Registry;
use fractum_engine::simulation::{End, TimeStep};
use fractum_engine::stage::Stage;
use fractum_scene::{Body, InitialVelocity, Output, Shape, Spec};
use std::fmt::Write as _;
use std::time::Instant;

/// A pipeline to benchmark; on the command line in kebab case (`linear-usl`, `dfg-contact`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum BenchPipeline {
    /// `basis/linear` + update-stress-last + linear elasticity.
    LinearUsl,
    /// `basis/gimp` + update-stress-last + linear elasticity: the cost of GIMP's wider rows.
    GimpUsl,
    /// `basis/bspline` (quadratic) + update-stress-last + linear elasticity: nine nodes per
    /// particle in 2D, as GIMP's widest rows, always.
    BsplineUsl,
    /// `basis/mls` + `predictor/mls` + linear elasticity + `advection/mls`: MLS-MPM on
    /// quadratic B-splines, the weights computed in the transfers, no connectivity.
    BsplineMls,
    /// `bspline-usl` with `advection/usl`'s `transfer: Apic`: the affine particle-in-cell
    /// transfer on the stored connectivity, whose cost beside `bspline-usl`'s FLIP is each
    /// particle's affine velocity `C_p`, written by the advection and read by the predictor.
    BsplineApic,
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
            BenchPipeline::BsplineUsl => "bspline+usl",
            BenchPipeline::BsplineMls => "bspline+mls",
            BenchPipeline::BsplineApic => "bspline+apic",
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
            BenchPipeline::BsplineUsl => usl_on(spec, "basis/bspline"),
            BenchPipeline::BsplineApic => spec
                .system("basis/bspline")
                .system("predictor/usl")
                .system("stress/linear_elastic")
                .system_with("advection/usl", "(transfer: Apic)"),
            BenchPipeline::BsplineMls => spec
                .system("basis/mls")
                .system("predictor/mls")
                .system("stress/linear_elastic")
                .system("advection/mls"),
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
        window: None,
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
    /// Bytes a particle-step moves, counted from what each system reads and writes
    /// ([`fractum_engine::traffic`]).
    pub bytes_per_particle_step: f64,
    /// Seconds per step of each stage, when profiled.
    pub stages: Option<Vec<(Stage, f64)>>,
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
    /// Time every stage too.
    pub profile: bool,
}

/// Runs one measurement: build, one warm-up step, then `case.steps` timed steps.
pub fn measure(registry: &Registry, case: BenchCase) -> Result<BenchResult, String> {
    let built = with_dim!(case.dimension, D => {
        bench_spec::<D>(case.pipeline, case.particles).build(registry)
    })
    .map_err(|e| e.to_string())?;
    let mut sim = built.simulation;
    sim.set_threads(case.threads).map_err(|e| e.to_string())?;
    if case.profile {
        sim.profile_stages()?;
    }
    let count = sim.particle_count();
    sim.step().map_err(|e| e.to_string())?;
    if let Some(mut clock) = sim.world.get_resource_mut::<StageClock>() {
        clock.reset();
    }
    let started = Instant::now();
    for _ in 0..case.steps {
        sim.step().map_err(|e| e.to_string())?;
    }
    let seconds = started.elapsed().as_secs_f64();
    let bytes: f64 = sim.traffic().iter().map(|t| t.bytes()).sum();
    Ok(BenchResult {
        pipeline: case.pipeline,
        dimension: case.dimension,
        particles: count,
        threads: case.threads,
        steps: case.steps,
        seconds,
        bytes_per_particle_step: bytes / count.max(1) as f64,
        stages: sim
            .world
            .get_resource::<StageClock>()
            .map(StageClock::per_step),
    })
}

/// Memory bandwidth (bytes/s) of a STREAM triad `a = b + s·c` over `elements` f64s per array
/// on `threads` threads: the best of five passes, counting 24 bytes per element (two reads and
/// a write, as STREAM does). Arrays must be well beyond the caches (STREAM asks for four times
/// the last-level cache); `fractum bench` uses 2²⁴ elements, 384 MiB in all.
pub fn triad_bandwidth(threads: usize, elements: usize) -> Result<f64, String> {
    use rayon::prelude::*;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.max(1))
        .build()
        .map_err(|e| e.to_string())?;
    pool.install(|| {
        // First touch on the threads that use the arrays, as the steps do.
        let filled = |value: f64| {
            let mut v = vec![0.0f64; elements];
            v.par_iter_mut().for_each(|x| *x = value);
            v
        };
        let (mut a, b, c) = (filled(0.0), filled(1.0), filled(2.0));
        let scalar = 3.0;
        let chunk = 1 << 14;
        let mut best = f64::INFINITY;
        for _ in 0..5 {
            let started = Instant::now();
            a.par_chunks_mut(chunk)
                .zip(b.par_chunks(chunk))
                .zip(c.par_chunks(chunk))
                .for_each(|((a, b), c)| {
                    for ((a, b), c) in a.iter_mut().zip(b).zip(c) {
                        *a = b + scalar * c;
                    }
                });
            best = best.min(started.elapsed().as_secs_f64());
        }
        if a.iter().any(|&x| x != 7.0) {
            return Err("the triad computed a wrong sum".to_string());
        }
        Ok(24.0 * elements as f64 / best.max(1e-12))
    })
}

/// The serial fraction of a step by the Karp–Flatt metric: from the speedup `speedup` on
/// `threads` threads, `e = (1/S − 1/p) / (1 − 1/p)`, the share of one thread's step that did
/// not run in parallel (load imbalance and synchronisation count as serial).
pub fn serial_fraction(speedup: f64, threads: usize) -> f64 {
    let p = threads as f64;
    (1.0 / speedup - 1.0 / p) / (1.0 - 1.0 / p)
}

/// Amdahl's speedup on `threads` threads of a step whose serial fraction is `serial`.
pub fn amdahl(serial: f64, threads: usize) -> f64 {
    1.0 / (serial + (1.0 - serial) / threads as f64)
}

/// The profile tables of `results`: the roofline of each measurement against the triad
/// bandwidth at its thread count (`bandwidth`, thread count → bytes/s), each stage's time per
/// step, and the serial fraction where one and more threads were measured.
pub fn profile_report(results: &[BenchResult], bandwidth: &[(usize, f64)]) -> String {
    [
        roofline_table(results, bandwidth),
        stage_table(results),
        scaling_table(results),
    ]
    .join("\n")
}

/// The columns that name a measurement: pipeline, dimension, particles, threads.
const KEY_HEADER: &str = "| pipeline | dim | particles | threads |";

/// `r`'s cells under [`KEY_HEADER`].
fn key(r: &BenchResult) -> String {
    format!(
        "| {} | {} | {} | {} |",
        r.pipeline.name(),
        dimension_name(r.dimension),
        r.particles,
        r.threads
    )
}

/// A table's header and its separator: the key columns, then `columns`.
fn header(columns: &[&str]) -> String {
    let rule = "| --- ".repeat(4 + columns.len());
    format!("\n{KEY_HEADER} {} |\n{rule}|\n", columns.join(" | "))
}

fn roofline_table(results: &[BenchResult], bandwidth: &[(usize, f64)]) -> String {
    let mut out = header(&[
        "bytes/particle-step",
        "triad GB/s",
        "attained GB/s",
        "of triad",
        "rate bound by triad",
    ]);
    for r in results {
        let Some(&(_, triad)) = bandwidth.iter().find(|(t, _)| *t == r.threads) else {
            continue;
        };
        let attained = r.rate() * r.bytes_per_particle_step;
        let _ = writeln!(
            out,
            "{} {:.0} | {:.1} | {:.1} | {:.0}% | {:.3e} |",
            key(r),
            r.bytes_per_particle_step,
            triad / 1e9,
            attained / 1e9,
            100.0 * attained / triad,
            triad / r.bytes_per_particle_step.max(1.0),
        );
    }
    out
}

fn stage_table(results: &[BenchResult]) -> String {
    let mut out = header(&["stage", "ms/step", "share", "speedup over 1 thread"]);
    for r in results {
        let Some(stages) = &r.stages else { continue };
        let total: f64 = stages.iter().map(|(_, s)| s).sum();
        let one = single_thread_twin(results, r).and_then(|one| one.stages.as_ref());
        for (stage, seconds) in stages {
            let speedup = one
                .and_then(|one| one.iter().find(|(s, _)| s == stage))
                .map_or(String::from("–"), |(_, s1)| {
                    format!("{:.2}", s1 / seconds)
                });
            let _ = writeln!(
                out,
                "{} {} | {:.3} | {:.1}% | {} |",
                key(r),
                stage.name(),
                1e3 * seconds,
                100.0 * seconds / total,
                speedup
            );
        }
    }
    out
}

fn scaling_table(results: &[BenchResult]) -> String {
    let mut out = header(&[
        "speedup",
        "serial fraction (Karp–Flatt)",
        "predicted speedup at 16 threads",
    ]);
    for r in results.iter().filter(|r| r.threads > 1) {
        let Some(one) = single_thread_twin(results, r) else {
            continue;
        };
        let speedup = r.rate() / one.rate();
        let serial = serial_fraction(speedup, r.threads);
        let _ = writeln!(
            out,
            "{} {:.2} | {:.3} | {:.1} |",
            key(r),
            speedup,
            serial,
            amdahl(serial.max(0.0), 16)
        );
    }
    out
}

/// The one-thread measurement of the same pipeline, dimension and size as `r`.
fn single_thread_twin<'a>(results: &'a [BenchResult], r: &BenchResult) -> Option<&'a BenchResult> {
    results.iter().find(|o| {
        o.threads == 1
            && o.pipeline == r.pipeline
            && o.dimension == r.dimension
            && o.particles == r.particles
    })
}

fn dimension_name(dimension: Dimension) -> &'static str {
    match dimension {
        Dimension::Two => "2D",
        Dimension::Three => "3D",
    }
}

/// Default number of timed steps: about two million particle-steps, at least 5.
pub fn default_steps(particles: usize) -> u64 {
    (2_000_000 / particles.max(1)).max(5) as u64
}

/// Markdown table of results.
pub fn table(results: &[BenchResult]) -> String {
    let mut out = header(&["steps", "wall (s)", "particle-steps/s"])
        .trim_start()
        .to_string();
    for r in results {
        let _ = writeln!(
            out,
            "{} {} | {:.3} | {:.3e} |",
            key(r),
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
            BenchPipeline::BsplineUsl,
            BenchPipeline::BsplineMls,
            BenchPipeline::BsplineApic,
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
                    profile: true,
                };
                let result = measure(&registry, case).unwrap();
                assert_eq!(result.particles, particles);
                assert!(result.rate() > 0.0);
                // Positions, velocities, stresses and the connectivity at the least.
                assert!(result.bytes_per_particle_step > 100.0, "{pipeline:?}");
                let stages = result.stages.unwrap();
                for stage in [
                    Stage::Basis,
                    Stage::Predictor,
                    Stage::Stress,
                    Stage::Advection,
                ] {
                    assert!(
                        stages.iter().any(|(s, t)| *s == stage && *t > 0.0),
                        "{stage:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn the_triad_measures_a_positive_bandwidth_and_checks_its_sum() {
        let bandwidth = triad_bandwidth(1, 1 << 12).unwrap();
        assert!(bandwidth.is_finite() && bandwidth > 0.0);
    }

    #[test]
    fn karp_flatt_recovers_the_serial_fraction_amdahl_was_given() {
        for serial in [0.0, 0.05, 0.3, 1.0] {
            for threads in [2, 4, 16] {
                let speedup = amdahl(serial, threads);
                assert!((serial_fraction(speedup, threads) - serial).abs() < 1e-12);
            }
        }
        assert!((amdahl(0.05, 16) - 1.0 / (0.05 + 0.95 / 16.0)).abs() < 1e-12);
    }

    #[test]
    fn the_profile_report_places_each_measurement_and_pairs_threads() {
        let result = |threads, seconds| BenchResult {
            pipeline: BenchPipeline::LinearUsl,
            dimension: Dimension::Two,
            particles: 1000,
            threads,
            steps: 10,
            seconds,
            bytes_per_particle_step: 2000.0,
            stages: Some(vec![(Stage::Basis, seconds / 10.0)]),
        };
        // 1e4 particle-steps in 1 s and 0.625 s: 1.6× on 2 threads, serial fraction 0.25.
        let results = [result(1, 1.0), result(2, 0.625)];
        let report = profile_report(&results, &[(1, 4.0e7), (2, 8.0e7)]);
        // 1e4 particle-steps/s × 2000 bytes = 2e7 bytes/s: half the one-thread triad.
        assert!(
            report.contains("| linear+usl | 2D | 1000 | 1 | 2000 | 0.0 | 0.0 | 50% | 2.000e4 |"),
            "{report}"
        );
        assert!(
            report.contains("| linear+usl | 2D | 1000 | 2 | basis | 62.500 | 100.0% | 1.60 |"),
            "{report}"
        );
        assert!(
            report.contains("| linear+usl | 2D | 1000 | 2 | 1.60 | 0.250 |"),
            "{report}"
        );
        assert_eq!(table(&results).lines().count(), 4);
    }
}
