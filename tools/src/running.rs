//! `fractum run`: the output folder's policy, checkpoints, and stopping cleanly on SIGINT or
//! SIGTERM (`fractum resume` is `resuming.rs`, and runs its steps here).
//!
//! A first signal lets the current step finish; the run then writes its outputs and a
//! checkpoint and exits with [`crate::EXIT_INTERRUPTED`]. A second signal exits at once with
//! [`crate::EXIT_ABANDONED`] (the last checkpoint and the outputs written so far are intact:
//! every file is replaced atomically).

use crate::cell_crossing::StartPositions;
use crate::{EXIT_ABANDONED, EXIT_BAD_SCENE, EXIT_BLOWUP, EXIT_INTERRUPTED, EXIT_IO};
use crate::{
    EXIT_RESOURCES, EXIT_USAGE, energy_warning, kinetic_warning, load, report_scene_error,
    summary_report,
};
use fractum_engine::communicator::Communicator;
use fractum_engine::energy::EnergyWatch;
use fractum_engine::quasi_static::KineticWatch;
use fractum_engine::registry::Registry;
use fractum_io::checkpoint::{CHECKPOINT_DIR, CheckpointEvery, SceneRecord, list_checkpoints};
use fractum_io::run::{CheckpointPlan, RunError, RunOptions, run_with};
use fractum_scene::SceneFile;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::time::{Duration, Instant};

/// The most threads `--threads` accepts: more than any machine this runs on has cores, and
/// few enough that the pool's stacks cannot exhaust memory.
pub const MAX_THREADS: usize = 1024;

/// What `run` and `resume` share on the command line.
#[derive(Debug, Clone, Default)]
pub struct RunSettings {
    /// Threads for the parallel kernels.
    pub threads: Option<usize>,
    /// Stop when the clock reaches this step.
    pub steps: Option<u64>,
    /// No progress bar.
    pub quiet: bool,
    /// Checkpoint schedule.
    pub checkpoint_every: Option<CheckpointEvery>,
    /// Checkpoints kept.
    pub keep_checkpoints: usize,
}

static INTERRUPTED: AtomicBool = AtomicBool::new(false);
static SIGNALS: AtomicU32 = AtomicU32::new(0);
/// What the handler says on the first signal: [`SAY_CHECKPOINT`], [`SAY_OUTPUTS`] (a
/// distributed run's rank 0) or nothing (its other ranks, which the launcher signals too).
static SIGNAL_NOTE: AtomicU32 = AtomicU32::new(SAY_CHECKPOINT);
const SAY_CHECKPOINT: u32 = 0;
const SAY_OUTPUTS: u32 = 1;
const SAY_NOTHING: u32 = 2;

/// Installs the SIGINT/SIGTERM handler once per process (later calls keep the first), saying
/// `note` ([`SIGNAL_NOTE`]) on the first signal.
fn handle_signals(note: u32) {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            let say = SIGNAL_NOTE.load(Ordering::SeqCst) != SAY_NOTHING;
            if SIGNALS.fetch_add(1, Ordering::SeqCst) >= 1 {
                if say {
                    eprintln!("\nsecond interrupt: exiting now");
                }
                std::process::exit(EXIT_ABANDONED);
            }
            INTERRUPTED.store(true, Ordering::SeqCst);
            match SIGNAL_NOTE.load(Ordering::SeqCst) {
                SAY_CHECKPOINT => eprintln!(
                    "\ninterrupt: finishing this step, then writing the outputs and a \
                     checkpoint (interrupt again to exit at once)"
                ),
                SAY_OUTPUTS => eprintln!(
                    "\ninterrupt: every rank finishes this step, then writes its outputs \
                     (interrupt again to exit at once)"
                ),
                _ => {}
            }
        });
    });
    SIGNAL_NOTE.store(note, Ordering::SeqCst);
    INTERRUPTED.store(false, Ordering::SeqCst);
    SIGNALS.store(0, Ordering::SeqCst);
}

/// The files and folders a run writes into its output folder.
const RUN_OUTPUTS: [&str; 5] = [
    "series.csv",
    "particles.pvd",
    "grid.pvd",
    "frames",
    CHECKPOINT_DIR,
];

/// Whether `dir` holds the outputs of a run.
fn holds_a_run(dir: &Path) -> bool {
    RUN_OUTPUTS.iter().any(|name| dir.join(name).exists())
}

/// Makes `dir` ready for a new run: refuses a folder that holds a previous run unless
/// `force`, which removes that run's outputs (and nothing else).
pub fn prepare_out_dir(dir: &Path, force: bool) -> Result<(), String> {
    if !holds_a_run(dir) {
        return Ok(());
    }
    if !force {
        // Resuming is a way out only where there is a checkpoint to resume from.
        let resume = if list_checkpoints(dir).is_empty() {
            String::new()
        } else {
            format!("`fractum resume {}` to continue it, ", dir.display())
        };
        return Err(format!(
            "{} holds a previous run (series.csv, frames, checkpoints); pass --force to \
             replace it, {resume}or --out for another folder",
            dir.display(),
        ));
    }
    for name in RUN_OUTPUTS {
        let path = dir.join(name);
        let removed = if path.is_dir() {
            std::fs::remove_dir_all(&path)
        } else if path.exists() {
            std::fs::remove_file(&path)
        } else {
            Ok(())
        };
        removed.map_err(|e| format!("cannot remove {}: {e}", path.display()))?;
    }
    Ok(())
}

/// The record of the scene at `scene` (its path made absolute where possible) and its `text`,
/// which checkpoints keep.
fn scene_record(scene: &Path, text: String) -> SceneRecord {
    SceneRecord {
        path: std::path::absolute(scene)
            .unwrap_or_else(|_| scene.to_path_buf())
            .display()
            .to_string(),
        text,
    }
}

fn default_out_dir(scene: &Path) -> PathBuf {
    let stem = scene.file_stem().map(|s| s.to_string_lossy().into_owned());
    Path::new("out").join(stem.unwrap_or_else(|| "run".into()))
}

fn progress_bar(quiet: bool) -> ProgressBar {
    if quiet {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(1_000_000);
    let style = ProgressStyle::with_template("[{elapsed_precise}] {bar:32} {msg} ETA {eta}")
        .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar
}

/// `fractum run`.
pub fn run_command(
    scene: &Path,
    out: Option<PathBuf>,
    force: bool,
    settings: &RunSettings,
    registry: &Registry,
) -> i32 {
    let (file, mut built) = match load(scene, registry) {
        Ok(loaded) => loaded,
        Err(e) => return report_scene_error(&e),
    };
    if let Err(code) = make_ready(&mut built.simulation, settings, false) {
        return code;
    }
    let out_dir = out.unwrap_or_else(|| default_out_dir(scene));
    if let Err(e) = prepare_out_dir(&out_dir, force) {
        eprintln!("error: {e}");
        return EXIT_IO;
    }
    let record = scene_record(scene, file.text);
    execute(built, &out_dir, record, None, settings, None)
}

/// What rank 0 says of a failure the ranks agreed on: rank 0's own message as it is (what every
/// rank found, such as a scene's error, is found by rank 0 first), another rank's with its rank.
pub(crate) fn rank_message(failure: fractum_engine::communicator::RankFailure) -> String {
    if failure.rank == 0 {
        failure.message
    } else {
        failure.to_string()
    }
}

/// `fractum run` as one of the ranks of `comm`, which an MPI launcher started: every rank
/// builds its part of the scene ([`fractum_scene::build_rank_simulation`]) and steps
/// it with the others; rank 0 prepares the output folder, writes the series and the frames'
/// indexes, and says what happened. Every rank returns the same exit code where they fail
/// together; a failure on one rank stops the others at the next point they agree.
pub fn run_ranks(
    scene: &Path,
    out: Option<PathBuf>,
    force: bool,
    settings: &RunSettings,
    registry: &Registry,
    comm: &dyn Communicator,
) -> i32 {
    let speaks = comm.rank() == 0;
    let refuse = |code: i32, message: &str| {
        if speaks {
            eprintln!("error: {message}");
        }
        code
    };
    let built = SceneFile::read(scene).and_then(|file| {
        let built = fractum_scene::build_rank_simulation(&file, registry, comm.rank(), comm.size());
        built.map(|built| (file, built))
    });
    let failure = built.as_ref().err().map(ToString::to_string);
    if let Err(failure) = comm.agree(failure.as_deref()) {
        return refuse(EXIT_BAD_SCENE, &rank_message(failure));
    }
    let Ok((file, mut built)) = built else {
        return EXIT_BAD_SCENE;
    };
    // The same check on every rank; a rank that cannot start its threads fails alone, so the
    // ranks agree before going on, and rank 0 says why.
    let ready = ready_to_run(&mut built.simulation, settings, false);
    let failure = ready.as_ref().err().map(|(_, message)| message.clone());
    if let Err(failure) = comm.agree(failure.as_deref()) {
        let code = ready.err().map_or(EXIT_RESOURCES, |(code, _)| code);
        return refuse(code, &rank_message(failure));
    }
    let out_dir = out.unwrap_or_else(|| default_out_dir(scene));
    let prepared = if speaks {
        prepare_out_dir(&out_dir, force).err()
    } else {
        None
    };
    if let Err(failure) = comm.agree(prepared.as_deref()) {
        return refuse(EXIT_IO, &failure.message);
    }
    let record = scene_record(scene, file.text);
    let mut settings = settings.clone();
    settings.quiet |= !speaks;
    execute(built, &out_dir, record, None, &settings, Some(comm))
}

/// Gives `sim` its threads and `--steps`, and checks that the run will take a step: all before
/// any output is touched, so a run or resume refused here leaves the output folder as it was.
/// `resuming`: `sim` holds a checkpoint. The exit code when refused, after saying why.
pub(crate) fn make_ready(
    sim: &mut fractum_engine::Simulation,
    settings: &RunSettings,
    resuming: bool,
) -> Result<(), i32> {
    ready_to_run(sim, settings, resuming).map_err(|(code, message)| {
        eprintln!("error: {message}");
        code
    })
}

/// Gives `sim` its threads and step cap and checks that the run will take a step (as
/// `make_ready` does before `fractum run`), with the exit code and the reason when refused, for
/// the caller to say.
pub fn ready_to_run(
    sim: &mut fractum_engine::Simulation,
    settings: &RunSettings,
    resuming: bool,
) -> Result<(), (i32, String)> {
    if let Some(n) = settings.threads
        && let Err(e) = sim.set_threads(n.max(1))
    {
        return Err((EXIT_RESOURCES, format!("cannot start {n} threads: {e}")));
    }
    sim.set_step_cap(settings.steps);
    if sim.finished() {
        let step = sim.clock().step;
        let message = if sim.at_end() {
            format!(
                "the run is already at the scene's end (step {step}, t = {:e} s); nothing is \
                 left to run",
                sim.clock().time
            )
        } else {
            format!(
                "the run is already at step {step}, where --steps stops it; pass a larger \
                 --steps, or none to go on to the scene's end"
            )
        };
        // Asking to run or resume to a step the run is at already is a command-line mistake;
        // a scene that ends before it starts is the scene's.
        let code = if resuming || settings.steps.is_some() {
            EXIT_USAGE
        } else {
            EXIT_BAD_SCENE
        };
        return Err((code, message));
    }
    Ok(())
}

/// Warns (on rank 0) when the run is mass scaled and its pipeline has laws that read the
/// scene's real time.
fn warn_of_real_time_laws(world: &fractum_engine::prelude::World, comm: Option<&dyn Communicator>) {
    if comm.is_none_or(|c| c.rank() == 0)
        && let Some(warning) = crate::reports::real_time_warning(world)
    {
        eprintln!("warning: {warning}");
    }
}

/// Steps a built (or restored) simulation to its end, writing its outputs and checkpoints, and
/// says how it ended; the exit code.
pub(crate) fn execute(
    mut built: fractum_scene::Built,
    out_dir: &Path,
    scene: SceneRecord,
    resume: Option<fractum_io::run::ResumedOutputs>,
    settings: &RunSettings,
    comm: Option<&dyn Communicator>,
) -> i32 {
    let sim = &mut built.simulation;
    handle_signals(match comm {
        None => SAY_CHECKPOINT,
        Some(comm) if comm.rank() == 0 => SAY_OUTPUTS,
        Some(_) => SAY_NOTHING,
    });
    let options = RunOptions {
        checkpoints: settings.checkpoint_every.map(|every| CheckpointPlan {
            every,
            keep: settings.keep_checkpoints.max(1),
        }),
        scene: Some(scene),
        interrupt: Some(&INTERRUPTED),
        resume,
        communicator: comm,
    };
    warn_of_real_time_laws(&sim.world, comm);
    let bar = progress_bar(settings.quiet);
    let started = Instant::now();
    let first_step = sim.clock().step;
    let mut last_draw = Instant::now();
    // Every rank watches the run's energy alike; rank 0 says so.
    let mut warned = comm.is_some_and(|c| c.rank() != 0);
    let mut kinetic_warned = warned;
    let start = if warned {
        None
    } else {
        StartPositions::of_linear_basis(&sim.world, &built.pipeline)
    };
    let result = run_with(sim, &built.output, out_dir, options, |sim| {
        if !warned
            && let Some(first) = sim
                .world
                .get_resource::<EnergyWatch>()
                .and_then(|w| w.first)
        {
            warned = true;
            let cells = start.as_ref().map(|s| s.cells_moved(&sim.world));
            bar.suspend(|| eprintln!("warning: {}", energy_warning(&first, cells)));
        }
        if !kinetic_warned
            && let Some((first, limit)) = sim
                .world
                .get_resource::<KineticWatch>()
                .filter(|w| w.broken)
                .and_then(|w| w.excess().map(|f| (f, w.limit)))
        {
            kinetic_warned = true;
            bar.suspend(|| eprintln!("warning: {}", kinetic_warning(&first, limit)));
        }
        if last_draw.elapsed() > Duration::from_millis(100) || sim.finished() {
            last_draw = Instant::now();
            let clock = sim.clock();
            let rate = (clock.step - first_step) as f64 / started.elapsed().as_secs_f64().max(1e-9);
            bar.set_position((sim.progress() * 1e6) as u64);
            bar.set_message(format!(
                "step {} t = {:.4e} s {rate:.0} steps/s",
                clock.step, clock.time
            ));
        }
    });
    bar.finish_and_clear();
    if comm.is_some_and(|c| c.rank() != 0) {
        // Rank 0 says what happened; every rank ends with the same code where they stopped
        // together.
        return exit_code(&result);
    }
    report_outcome(result, sim, &built.pipeline, out_dir)
}

/// The exit code of a run's outcome (as [`report_outcome`] returns it, without a word).
fn exit_code(result: &Result<fractum_io::run::RunSummary, RunError>) -> i32 {
    match result {
        Ok(summary) if summary.interrupted => EXIT_INTERRUPTED,
        Ok(_) => 0,
        Err(RunError::Blowup(..) | RunError::Rank(..)) => EXIT_BLOWUP,
        Err(_) => EXIT_IO,
    }
}

/// Prints what a run did, or why it stopped, and returns the exit code.
fn report_outcome(
    result: Result<fractum_io::run::RunSummary, RunError>,
    sim: &fractum_engine::Simulation,
    pipeline: &fractum_scene::PipelineSummary,
    out_dir: &Path,
) -> i32 {
    match result {
        Ok(summary) => {
            out!("{}", summary_report(&summary, out_dir));
            if let Some(path) = &summary.checkpoint {
                outln!("checkpoint {}", path.display());
            }
            if summary.interrupted {
                match &summary.checkpoint {
                    Some(_) => eprintln!(
                        "interrupted at step {}; continue with `fractum resume {}`",
                        sim.clock().step,
                        out_dir.display()
                    ),
                    None => eprintln!(
                        "interrupted at step {}; the outputs up to it are in {}",
                        sim.clock().step,
                        out_dir.display()
                    ),
                }
                return EXIT_INTERRUPTED;
            }
            0
        }
        Err(RunError::Blowup(b, last_good)) => {
            eprintln!("error: the run stopped at {b}");
            if let Some(cure) = crate::remedy::remedy(b.cause, &pipeline.system_names()) {
                eprintln!("{cure}");
            }
            eprintln!(
                "outputs up to the last output step are in {}",
                out_dir.display()
            );
            if let Some(path) = last_good {
                eprintln!(
                    "the state at the start of step {} is in {}",
                    b.step,
                    path.display()
                );
            }
            EXIT_BLOWUP
        }
        Err(RunError::Rank(failure, last_good)) => {
            eprintln!("error: the run stopped on {failure}");
            eprintln!(
                "outputs up to the last output step are in {}",
                out_dir.display()
            );
            if let Some(path) = last_good {
                eprintln!(
                    "the state at the start of the failing step is in {}",
                    path.display()
                );
            }
            EXIT_BLOWUP
        }
        Err(e) => {
            eprintln!("error: {e}");
            EXIT_IO
        }
    }
}
