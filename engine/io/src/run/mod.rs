//! The run loop: step to the end, writing frames and time-series rows on schedule, with
//! checkpoints; [`resume_from`] continues a run from one.

mod checkpoints;
pub mod distributed;
mod outputs;
pub mod rank_clock;
mod resume;

use checkpoints::{CheckpointSchedule, checkpoint_now};
use outputs::{Outputs, open_outputs, write_last_good};
pub use resume::{restore_checkpoint, resume_from, resumed_outputs, rewind_outputs};

use crate::checkpoint::{
    CheckpointEvery, CheckpointOutputs, DEFAULT_KEEP, SceneRecord, write_checkpoint,
    write_rank_manifest, write_rank_piece,
};
use crate::output::{
    FrameWriter, OutputPlan, SeriesWriter, WriteFailure, grid_frame, largest_energy_particle,
    must_be_finite, particle_frame, piece_name, series_parts, series_row_from,
    write_particle_frame, write_pvtu,
};
use fractum_engine::communicator::{Communicator, RankFailure};
use fractum_engine::energy::{EnergyBalance, EnergyWatch};
use fractum_engine::health::Blowup;
use fractum_engine::quasi_static::KineticWatch;
use fractum_engine::resources::SimClock;
use fractum_engine::simulation::Simulation;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

impl From<crate::checkpoint::WriteError> for RunError {
    fn from(e: crate::checkpoint::WriteError) -> Self {
        match e {
            crate::checkpoint::WriteError::Encode(message) => RunError::Checkpoint(message),
            crate::checkpoint::WriteError::Io { path, source } => RunError::Io { path, source },
        }
    }
}

/// Why a run did not finish.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The state became invalid. Outputs up to the previous output step are on disk, and the
    /// state at the start of the failing step too when the plan keeps it.
    #[error("the run stopped at {0}")]
    Blowup(Blowup, Option<PathBuf>),
    /// A rank of a distributed run failed (a blow-up it found, an exchange or a file it could
    /// not write), and every rank stopped with its message. The path is the `.pvtu` index of
    /// the state at the start of the failing step, when the plan keeps it.
    #[error("the run stopped on {0}")]
    Rank(RankFailure, Option<PathBuf>),
    /// Another rank of a distributed run could not go on (an output it could not write), and
    /// this one stopped with it.
    #[error("the run stopped with {0}")]
    OtherRank(RankFailure),
    /// A checkpoint could not be made.
    #[error("cannot write a checkpoint: {0}")]
    Checkpoint(String),
    /// An output file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// What a finished run did.
#[derive(Clone, Debug)]
pub struct RunSummary {
    /// Steps taken.
    pub steps: u64,
    /// Simulated time reached.
    pub time: f64,
    /// Particles.
    pub particles: usize,
    /// Threads used by the parallel kernels.
    pub threads: usize,
    /// Threads asked for (more than `threads` when a small scene ran on one thread).
    pub threads_asked: usize,
    /// Wall-clock time of the stepping loop (output included).
    pub wall: Duration,
    /// VTU frames written.
    pub frames: usize,
    /// Particles removed on leaving the grid.
    pub removed: u64,
    /// The most energy the scheme created, when it passed the watch's warning level
    /// ([`EnergyWatch`]).
    pub energy_created: Option<fractum_engine::energy::EnergyCreation>,
    /// A quasi-static run's largest kinetic fraction over the upper half of its loading, when
    /// it passed the scene's limit ([`KineticWatch`]).
    pub kinetic_excess: Option<fractum_engine::quasi_static::KineticExcess>,
    /// The energy account of the last series row, if a row was written.
    pub energy_balance: Option<fractum_engine::energy::EnergyBalance>,
    /// Whether the run stopped early on [`RunOptions::interrupt`].
    pub interrupted: bool,
    /// Whether the pipeline splits nodes by damage ([`fractum_engine::fields::FieldSplits`]) and no node
    /// was split in the whole run (counting the steps before a resume).
    pub never_split: bool,
    /// The last checkpoint written, if any.
    pub checkpoint: Option<PathBuf>,
    /// How a distributed run divided its work over the ranks (`None` in one process).
    pub ranks: Option<RankReport>,
}

/// How a distributed run divided its work, the same on every rank: the load balance and what
/// the halos cost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RankReport {
    /// Ranks.
    pub ranks: usize,
    /// How often the slabs were re-cut to balance the ranks' loads.
    pub rebalances: u64,
    /// How far the most loaded rank was over the mean after the last step (0.05: 5%), its
    /// particles and nodes counted (`decomposition::layer_loads`).
    pub imbalance: f64,
    /// The particles the ranks held at the end, owned and ghosts, over the run's particles: what
    /// the halos add to the work.
    pub held_over_owned: f64,
    /// Bytes every rank sent to others per step of this run, on average over the ranks.
    pub sent_per_step: f64,
    /// The nodes the ranks held at the end over the grid's: what the overlap of the nodes
    /// their particles reach adds.
    pub held_nodes_over_grid: f64,
    /// How often, over every rank, a re-cut moved a rank's nodes so that its world was built
    /// afresh for the new slabs.
    pub rebuilds: u64,
    /// The seconds a rank spent in each phase of its steps, in the order of
    /// [`rank_clock::Phase::ALL`], on average over the ranks ([`rank_clock::RankClock`]).
    pub phase_seconds: [f64; rank_clock::Phase::ALL.len()],
    /// The least and the greatest over the ranks of each phase's seconds, in the same order:
    /// where the particle and node counts balance the ranks but their times do not (a rank
    /// whose particles cost more, one waiting for the other), the spread shows it.
    pub phase_range: [(f64, f64); rank_clock::Phase::ALL.len()],
}

impl RunSummary {
    /// Particle-steps per second of wall time.
    pub fn particle_steps_per_second(&self) -> f64 {
        self.particles as f64 * self.steps as f64 / self.wall.as_secs_f64().max(1e-12)
    }
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> RunError + '_ {
    move |source| RunError::Io {
        path: path.to_path_buf(),
        source,
    }
}

impl From<WriteFailure> for RunError {
    fn from((path, source): WriteFailure) -> Self {
        RunError::Io { path, source }
    }
}

/// What a run does besides stepping: checkpoints, interruption, continuing the outputs of an
/// earlier run, and the ranks of a distributed run.
#[derive(Default)]
pub struct RunOptions<'a> {
    /// Write checkpoints on this schedule (and at the end and on interruption).
    pub checkpoints: Option<CheckpointPlan>,
    /// The scene the run was built from, recorded in checkpoints so `resume` can rebuild it.
    pub scene: Option<SceneRecord>,
    /// Set (by a signal handler) to stop after the current step: the run writes its outputs
    /// and a checkpoint, and returns with [`RunSummary::interrupted`] set.
    pub interrupt: Option<&'a AtomicBool>,
    /// Continue the outputs of the run a checkpoint was taken from.
    pub resume: Option<ResumedOutputs>,
    /// Run as one rank of a distributed run, on a rank's simulation
    /// (`fractum_scene::build_rank_simulation`): every step agreed with the other ranks
    /// ([`distributed::step`]), the series made from the ranks' sums and written by rank 0,
    /// each frame one piece per rank with a `.pvtu` index, and a failure on any rank stopping
    /// every rank. `None`: one process.
    pub communicator: Option<&'a dyn Communicator>,
}

/// When checkpoints are written and how many are kept.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CheckpointPlan {
    /// Every so many steps or so much simulated time.
    pub every: CheckpointEvery,
    /// The newest this many are kept; older ones are deleted.
    pub keep: usize,
}

/// The outputs of an earlier run, as its checkpoint recorded them.
#[derive(Clone, Debug, PartialEq)]
pub struct ResumedOutputs {
    /// The series text at the checkpoint (header included).
    pub series: String,
    /// The particle frames written by then: (time, file).
    pub frames: Vec<(f64, String)>,
    /// The grid frames written by then.
    pub grid_frames: Vec<(f64, String)>,
    /// The simulated time of the next checkpoint on a time schedule.
    pub next_checkpoint_time: Option<f64>,
}

/// Steps `sim` to its end, writing `out_dir/series.csv`, `out_dir/frames/*.vtu` and
/// `out_dir/particles.pvd`. `on_step` is called after every step (for progress display).
pub fn run(
    sim: &mut Simulation,
    plan: &OutputPlan,
    out_dir: &Path,
    on_step: impl FnMut(&Simulation),
) -> Result<RunSummary, RunError> {
    run_with(sim, plan, out_dir, RunOptions::default(), on_step)
}

/// [`run`] with checkpoints, interruption and resumption ([`RunOptions`]).
pub fn run_with(
    sim: &mut Simulation,
    plan: &OutputPlan,
    out_dir: &Path,
    options: RunOptions,
    mut on_step: impl FnMut(&Simulation),
) -> Result<RunSummary, RunError> {
    let comm = options.communicator;
    let frames_dir = out_dir.join("frames");
    let made = std::fs::create_dir_all(&frames_dir).map_err(io_error(&frames_dir));
    agreed(comm, made)?;
    if comm.is_none_or(|c| c.rank() == 0) {
        remove_stale_temporaries(out_dir);
    }
    let mut options = options;
    let resumed = options.resume.is_some();
    let resume = options.resume.take();
    let opened = open_outputs(sim, plan, out_dir, options.checkpoints, resume, comm);
    let (mut outputs, mut schedule) = agreed(comm, opened)?;
    let started = Started::now(sim, comm);
    if !resumed {
        if let Some(comm) = comm {
            // Each rank's watch starts from the floor of the particles it owns: the run's is
            // their sum.
            let mut watch = sim.world.resource_mut::<EnergyWatch>();
            watch.scale = comm.sum(&[watch.scale])[0];
            if let Some(mut kinetic) = sim.world.get_resource_mut::<KineticWatch>() {
                kinetic.floor = comm.sum(&[kinetic.floor])[0];
            }
        }
        let first = outputs.record(sim, true);
        agreed(comm, first)?;
    }
    let mut interrupted = false;
    let mut checkpoint = None;
    // The state at the start of the step, refilled in place each step (no allocation).
    let mut last_good = crate::output::LastGoodState::default();
    while !sim.finished() {
        if plan.last_good_frame {
            sim.with_world_in_pool(|world| last_good.refill(world));
        }
        // The step the state was at: a rank whose step failed has not moved its clock, the
        // others have.
        let step = sim.clock().step;
        if let Err(failure) = step_once(sim, comm) {
            let settled = outputs.settle();
            let last_good = plan.last_good_frame.then(|| last_good.frame()).flatten();
            let written = write_last_good(plan, &frames_dir, step, last_good.as_ref(), comm);
            let written = agreed(comm, settled.and(written))?;
            let listed = outputs.list_every_frame();
            agreed(comm, listed)?;
            return Err(failure.with_last_good(written));
        }
        let recorded = outputs.record(sim, false);
        agreed(comm, recorded)?;
        interrupted = interrupt_seen(&options, comm);
        let last = sim.finished() || interrupted;
        let wanted = options.checkpoints.is_some() || interrupted;
        if wanted && (schedule.due(sim.clock()) || last) {
            checkpoint = Some(checkpoint_now(
                sim,
                out_dir,
                &options,
                &mut outputs,
                &schedule,
            )?);
        }
        if last {
            let recorded = outputs.record(sim, true);
            agreed(comm, recorded)?;
        }
        on_step(sim);
        if interrupted {
            break;
        }
    }
    finish(sim, comm, &mut outputs, started, interrupted, checkpoint)
}

/// Whether an interrupt was seen: here, or on any rank of a distributed run.
fn interrupt_seen(options: &RunOptions, comm: Option<&dyn Communicator>) -> bool {
    let seen = options
        .interrupt
        .is_some_and(|flag| flag.load(Ordering::SeqCst));
    match comm {
        // A signal reaches the ranks at different steps: they stop at the first step after
        // any of them saw it.
        Some(comm) => comm.max(f64::from(u8::from(seen))) > 0.0,
        None => seen,
    }
}

/// Where a run started: its particles (every rank's), the wall clock, the step, and what
/// this rank had sent before (a resumed run's earlier steps).
struct Started {
    particles: usize,
    at: Instant,
    first_step: u64,
    sent_before: u64,
}

impl Started {
    /// A run starting now from the state of `sim`.
    fn now(sim: &mut Simulation, comm: Option<&dyn Communicator>) -> Self {
        let particles = match comm {
            Some(comm) => comm.sum(&[owned_particles(sim) as f64])[0] as usize,
            None => sim.particle_count(),
        };
        let sent_before = (sim
            .world
            .get_resource::<fractum_engine::decomposition::Ownership>())
        .map_or(0, |o| o.sent_bytes);
        Self {
            particles,
            at: Instant::now(),
            first_step: sim.clock().step,
            sent_before,
        }
    }
}

/// Ends a run whose loop has stopped: its files made safe and listed, then its summary.
fn finish(
    sim: &mut Simulation,
    comm: Option<&dyn Communicator>,
    outputs: &mut Outputs,
    started: Started,
    interrupted: bool,
    checkpoint: Option<PathBuf>,
) -> Result<RunSummary, RunError> {
    // The run ends only when its files are safe.
    let settled = outputs.settle();
    agreed(comm, settled)?;
    let listed = outputs.list_every_frame();
    agreed(comm, listed)?;
    let split_here = sim
        .world
        .get_resource::<fractum_engine::fields::FieldSplits>()
        .map(|s| s.first.is_some());
    // Each rank records the splits at the nodes it owns: the run split where any rank did.
    let split = split_here.map(|here| match comm {
        Some(comm) => comm.max(f64::from(u8::from(here))) > 0.0,
        None => here,
    });
    let clock = sim.clock();
    Ok(RunSummary {
        steps: clock.step - started.first_step,
        time: clock.time,
        particles: started.particles,
        threads: sim.threads(),
        threads_asked: sim.threads_asked(),
        wall: started.at.elapsed(),
        frames: outputs.frames.len(),
        removed: sim
            .world
            .resource::<fractum_engine::health::EscapedParticles>()
            .count,
        energy_created: sim
            .world
            .get_resource::<EnergyWatch>()
            .and_then(|w| w.worst),
        kinetic_excess: sim
            .world
            .get_resource::<KineticWatch>()
            .and_then(KineticWatch::excess),
        energy_balance: sim.world.get_resource::<EnergyBalance>().copied(),
        interrupted,
        never_split: split == Some(false),
        checkpoint,
        ranks: comm.map(|comm| {
            rank_report(
                sim,
                comm,
                clock.step - started.first_step,
                started.sent_before,
            )
        }),
    })
}

/// The [`RankReport`] of a distributed run that took `steps` steps, every rank calling it;
/// `sent_before` is what this rank had sent before them (a resumed run's earlier steps).
fn rank_report(
    sim: &mut Simulation,
    comm: &dyn Communicator,
    steps: u64,
    sent_before: u64,
) -> RankReport {
    let ownership = sim
        .world
        .get_resource::<fractum_engine::decomposition::Ownership>();
    let (rebalances, imbalance, sent, rebuilds) = ownership.map_or((0, 0.0, 0, 0), |o| {
        (
            o.rebalances,
            o.imbalance,
            o.sent_bytes - sent_before.min(o.sent_bytes),
            o.rebuilds,
        )
    });
    let held = sim.particle_count() as f64;
    let owned = owned_particles(sim) as f64;
    let world = &sim.world;
    let (nodes, grid_nodes) = fractum_engine::with_dim!(sim.dimension(), D => {
        let grid = world.resource::<fractum_engine::resources::Grid<D>>();
        (grid.node_count(), grid.global_node_count())
    });
    let clock = (sim.world.get_resource::<rank_clock::RankClock>())
        .copied()
        .unwrap_or_default();
    let phases = rank_clock::Phase::ALL.map(|p| clock.spent(p).as_secs_f64());
    let every_rank = comm.all_gather(&phases);
    let per_rank = fractum_engine::communicator::sum_in_rank_order(&every_rank, phases.len());
    let sums = comm.sum(&[held, owned, sent as f64, nodes as f64, rebuilds as f64]);
    RankReport {
        ranks: comm.size(),
        rebalances,
        imbalance,
        held_over_owned: sums[0] / sums[1].max(1.0),
        sent_per_step: sums[2] / comm.size() as f64 / steps.max(1) as f64,
        held_nodes_over_grid: sums[3] / grid_nodes.max(1) as f64,
        rebuilds: sums[4] as u64,
        phase_seconds: std::array::from_fn(|k| per_rank[k] / comm.size() as f64),
        phase_range: rank_clock::ranges_over_ranks(&every_rank),
    }
}

/// Why a step failed: a blow-up of one process, or the failure every rank agreed on.
enum StepFailure {
    Blowup(Blowup),
    Rank(RankFailure),
}

impl StepFailure {
    /// The run's error, with the state at the start of the failing step when it was written.
    fn with_last_good(self, written: Option<PathBuf>) -> RunError {
        match self {
            StepFailure::Blowup(blowup) => RunError::Blowup(blowup, written),
            StepFailure::Rank(failure) => RunError::Rank(failure, written),
        }
    }
}

/// One step: of the process, or of this rank with the others ([`distributed::step`]).
fn step_once(sim: &mut Simulation, comm: Option<&dyn Communicator>) -> Result<(), StepFailure> {
    match comm {
        Some(comm) => distributed::step(sim, comm).map_err(StepFailure::Rank),
        None => sim.step().map_err(StepFailure::Blowup),
    }
}

/// `result` where every rank got through it; else this rank's own error where it failed, and
/// on the other ranks the failure of the lowest failing rank ([`RunError::OtherRank`]);
/// `result` itself in one process. Every rank calls it at the same point, so that no rank
/// waits for one that has stopped.
fn agreed<T>(comm: Option<&dyn Communicator>, result: Result<T, RunError>) -> Result<T, RunError> {
    let Some(comm) = comm else {
        return result;
    };
    let message = result.as_ref().err().map(ToString::to_string);
    let agreement = comm.agree(message.as_deref());
    let value = result?;
    agreement.map_err(RunError::OtherRank)?;
    Ok(value)
}

/// The particles this rank owns (every particle of one process).
fn owned_particles(sim: &mut Simulation) -> usize {
    let owned = (sim
        .world
        .get_resource::<fractum_engine::decomposition::Ownership>())
    .map(|o| o.particles.iter().filter(|&&owned| owned).count());
    owned.unwrap_or_else(|| sim.particle_count())
}

/// Removes the temporary files an atomic write leaves when the process is killed in the
/// middle of it (`.series.csv.<pid>.tmp`): hidden, and never matched by `*.csv` or `*.vtu`.
pub fn remove_stale_temporaries(out_dir: &Path) {
    for dir in [
        out_dir.to_path_buf(),
        out_dir.join("frames"),
        out_dir.join("checkpoints"),
    ] {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.flatten() {
            let name = entry.file_name();
            let name = name.to_string_lossy();
            if name.starts_with('.') && name.ends_with(".tmp") {
                let _ = std::fs::remove_file(entry.path());
            }
        }
    }
}
