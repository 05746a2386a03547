//! The run loop: step to the end, writing frames and time-series rows on schedule, with
//! checkpoints; [`resume_from`] continues a run from one.

pub mod distributed;
mod resume;

pub use resume::{restore_checkpoint, resume_from, resumed_outputs, rewind_outputs};

use crate::checkpoint::{
    CheckpointEvery, CheckpointOutputs, DEFAULT_KEEP, SceneRecord, write_checkpoint,
    write_rank_manifest, write_rank_piece,
};
use crate::output::{
    FrameWriter, OutputPlan, SeriesWriter, WriteFailure, grid_frame, largest_energy_particle,
    must_be_finite, particle_frame, piece_name, refill_particle_frame, series_parts,
    series_row_from, write_particle_frame, write_pvtu,
};
use fractum_engine::communicator::{Communicator, RankFailure};
use fractum_engine::energy::EnergyWatch;
use fractum_engine::health::Blowup;
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
    /// How often the slabs were re-cut to balance the ranks' particles.
    pub rebalances: u64,
    /// How far the most loaded rank was over the mean after the last step (0.05: 5%).
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

/// Feeds a series row (time, kinetic, strain, total, …, work, residual) to the world's
/// [`EnergyWatch`], with the balance `W_ext − (E − E₀)` left before the damage laws' own
/// `dissipated_energy` accounts: dissipation is never negative, so a total energy above the
/// work done is created energy whatever those accounts say (the uniaxial account of the
/// Rankine laws reads up to 25% high, which alone would look like creation).
/// `initial` is the run's initial energy: in a distributed run the sum of the ranks' parts,
/// not this rank's account's.
fn watch_energy(sim: &mut Simulation, row: &[f64], initial: f64) {
    let step = sim.clock().step;
    let n = row.len();
    let (total, work) = (row[3], row[n - 2]);
    let mut watch = sim.world.get_resource_or_init::<EnergyWatch>();
    watch.observe(step, row[0], total, initial, work, work - (total - initial));
}

struct Outputs<'a> {
    plan: &'a OutputPlan,
    dir: &'a Path,
    /// The ranks of a distributed run, `None` in one process.
    comm: Option<&'a dyn Communicator>,
    series: SeriesWriter,
    frames: Vec<(f64, String)>,
    grid_frames: Vec<(f64, String)>,
    /// The particle and grid frames a resumed run began with, written before it.
    inherited: [usize; 2],
    /// The step of the last row, particle frame and grid frame written.
    written: [Option<u64>; 3],
    /// Encodes and writes the frames while the next steps compute.
    writer: FrameWriter,
}

impl Outputs<'_> {
    /// Writes the outputs due at this step, or every output not yet written at this step when
    /// `force` (the end of a run). The series is flushed with every frame, so frames and series
    /// never disagree by more than one output interval.
    fn record(&mut self, sim: &mut Simulation, force: bool) -> Result<(), RunError> {
        let result = self.record_unflushed(sim, force);
        if result.is_err() {
            // Keep the rows taken so far: a failed frame write must not lose them too.
            let _ = self.series.flush();
        }
        result
    }

    fn record_unflushed(&mut self, sim: &mut Simulation, force: bool) -> Result<(), RunError> {
        let step = sim.clock().step;
        let due = |every: u64| every > 0 && step.is_multiple_of(every);
        let fresh = |slot: Option<u64>| slot != Some(step);
        // One process stops at the first failure. A rank of a distributed run goes through
        // every part, whatever failed before on it, so that it takes part in every collective
        // the other ranks do (a row's sum, a frame's index writer), and reports its first
        // failure after them.
        let mut failed = Failures {
            distributed: self.comm.is_some(),
            first: None,
        };
        let row_due = due(self.plan.csv_every) || (self.plan.csv_every == 0 && step == 0);
        if (force || row_due) && fresh(self.written[0]) {
            self.written[0] = Some(step);
            failed.keep(self.row(sim, step))?;
        }
        let mut framed = false;
        if self.plan.vtu_every > 0 && (force || due(self.plan.vtu_every)) && fresh(self.written[1])
        {
            self.written[1] = Some(step);
            failed.keep(self.particle_frame(sim, step))?;
            framed = true;
        }
        if self.plan.grid_every > 0
            && (force || due(self.plan.grid_every))
            && fresh(self.written[2])
        {
            self.written[2] = Some(step);
            failed.keep(self.grid_frame(sim, step))?;
            framed = true;
        }
        if framed {
            failed.keep(self.flush())?;
        }
        failed.first.map_or(Ok(()), Err)
    }

    /// Writes the particle frame of `step` (this rank's piece of it, in a distributed run) and
    /// the collection that lists it.
    fn particle_frame(&mut self, sim: &mut Simulation, step: u64) -> Result<(), RunError> {
        let mut frame = sim.with_world_in_pool(particle_frame);
        if let Some(fields) = &self.plan.frame_fields {
            frame.keep_only(fields);
        }
        let name = match self.comm {
            None => {
                let name = format!("frames/particles_{step:08}.vtu");
                self.writer.particles(self.dir.join(&name), frame)?;
                name
            }
            Some(comm) => {
                let (piece, index) =
                    self.pieces(comm, &format!("particles_{step:08}"), frame.position.len());
                self.writer.particle_piece(piece, frame, index)?;
                format!("frames/particles_{step:08}.pvtu")
            }
        };
        self.frames.push((sim.clock().time, name));
        self.list_frames(false)
    }

    /// Writes the `.pvd` collections (rank 0 of a distributed run) with the frames whose every
    /// piece is on disk: one process's writer writes its collection after its frames, but the
    /// other ranks' pieces may still be in flight, so the ranks agree on how many frames each
    /// has written (every rank calls it at the same output step). `grid` for the grid frames.
    fn list_frames(&mut self, grid: bool) -> Result<(), RunError> {
        let (frames, name, k) = if grid {
            (&self.grid_frames, "grid.pvd", 1)
        } else {
            (&self.frames, "particles.pvd", 0)
        };
        let listed = match self.comm {
            None => frames.len(),
            Some(comm) => {
                let written = self.writer.frames_written();
                let here = if grid { written.1 } else { written.0 };
                (self.inherited[k] + comm.min(here as f64) as usize).min(frames.len())
            }
        };
        if self.comm.is_none_or(|c| c.rank() == 0) {
            let pvd = self.dir.join(name);
            self.writer.collection(pvd, frames[..listed].to_vec())?;
        }
        Ok(())
    }

    /// Lists every frame in the collections of a distributed run, once every rank has settled
    /// its files ([`Outputs::settle`] and an agreement): the collections then name every
    /// frame, as one process's do. Nothing to do in one process.
    fn list_every_frame(&mut self) -> Result<(), RunError> {
        let Some(comm) = self.comm else {
            return Ok(());
        };
        if comm.rank() == 0 {
            for (name, frames) in [
                ("particles.pvd", &self.frames),
                ("grid.pvd", &self.grid_frames),
            ] {
                if !frames.is_empty() {
                    self.writer
                        .collection(self.dir.join(name), frames.clone())?;
                }
            }
        }
        self.writer.wait().map_err(RunError::from)
    }

    /// Writes the grid frame of `step` (this rank's piece of it, in a distributed run) and the
    /// collection that lists it.
    fn grid_frame(&mut self, sim: &mut Simulation, step: u64) -> Result<(), RunError> {
        let frame = grid_frame(&mut sim.world);
        let name = match self.comm {
            None => {
                let name = format!("frames/grid_{step:08}.vtu");
                self.writer.grid(self.dir.join(&name), frame)?;
                name
            }
            Some(comm) => {
                let (piece, index) =
                    self.pieces(comm, &format!("grid_{step:08}"), frame.position.len());
                self.writer.grid_piece(piece, frame, index)?;
                format!("frames/grid_{step:08}.pvtu")
            }
        };
        self.grid_frames.push((sim.clock().time, name));
        self.list_frames(true)
    }

    /// This rank's piece of the frame `frames/{stem}.pvtu` of a distributed run, which holds
    /// `count` points, and the index when this rank writes it: the lowest rank with points, so
    /// that the index declares the arrays a piece with points has (every rank takes part).
    fn pieces(
        &self,
        comm: &dyn Communicator,
        stem: &str,
        count: usize,
    ) -> (PathBuf, Option<crate::output::PieceIndex>) {
        let index = format!("{stem}.pvtu");
        let pieces: Vec<String> = (0..comm.size()).map(|r| piece_name(&index, r)).collect();
        let frames = self.dir.join("frames");
        let piece = frames.join(&pieces[comm.rank()]);
        let writer = index_writer(comm, count);
        let index = (writer == comm.rank()).then(|| (frames.join(&index), pieces));
        (piece, index)
    }

    fn row(&mut self, sim: &mut Simulation, step: u64) -> Result<(), RunError> {
        // A rank's parts are sums over what it owns: the run's row is made from their sum.
        let parts = series_parts(&mut sim.world, self.plan);
        let parts = match self.comm {
            Some(comm) => comm.sum(&parts),
            None => parts,
        };
        let row = series_row_from(&mut sim.world, self.plan, &parts);
        // Energies and momentum of finite states can still overflow (speeds near 1e200), and a
        // probe or a system's column can still divide by a vanishing quantity: a row holding
        // either is no result. The stage checks have passed, so every particle is finite; the
        // most energetic one is named to place the overflow.
        let broken = (0..row.len()).find(|&i| !row[i].is_finite() && must_be_finite(self.plan, i));
        if let Some(column) = broken {
            self.settle()?;
            let name = &self.plan.columns()[column + 1];
            return Err(RunError::Blowup(
                Blowup::new(
                    step,
                    fractum_engine::stage::Stage::PostStep,
                    format!(
                        "the series column {name} is {} after the step: {}",
                        row[column],
                        largest_energy_particle(&mut sim.world)
                    ),
                ),
                None,
            ));
        }
        watch_energy(sim, &row, crate::output::initial_energy_part(&parts));
        let path = self.dir.join("series.csv");
        self.series.push(step, &row).map_err(io_error(&path))
    }

    fn flush(&mut self) -> Result<(), RunError> {
        let path = self.dir.join("series.csv");
        self.series.flush().map_err(io_error(&path))
    }

    /// Flushes the series and waits until every frame handed to the writer is on disk.
    fn settle(&mut self) -> Result<(), RunError> {
        let series = self.flush();
        self.writer.wait()?;
        series
    }
}

/// The rank that writes the `.pvtu` index of a frame whose piece on this rank holds `count`
/// points: the lowest rank whose piece has points, rank 0 when none has. Every rank calls it.
fn index_writer(comm: &dyn Communicator, count: usize) -> usize {
    let counts = comm.all_gather(&[count as f64]);
    counts.iter().position(|&n| n > 0.0).unwrap_or(0)
}

/// The failures of the parts of an output step: one process stops at the first; a rank of a
/// distributed run keeps the first and goes on ([`Outputs::record`]).
struct Failures {
    distributed: bool,
    first: Option<RunError>,
}

impl Failures {
    /// `part`'s failure, for the caller to stop at in one process; kept in a distributed run.
    fn keep(&mut self, part: Result<(), RunError>) -> Result<(), RunError> {
        match part {
            Err(e) if self.distributed => {
                self.first.get_or_insert(e);
                Ok(())
            }
            other => other,
        }
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
    let particles = match comm {
        Some(comm) => comm.sum(&[owned_particles(sim) as f64])[0] as usize,
        None => sim.particle_count(),
    };
    let started = Instant::now();
    let first_step = sim.clock().step;
    let sent_before = (sim
        .world
        .get_resource::<fractum_engine::decomposition::Ownership>())
    .map_or(0, |o| o.sent_bytes);
    if !resumed {
        if let Some(comm) = comm {
            // Each rank's watch starts from the floor of the particles it owns: the run's is
            // their sum.
            let mut watch = sim.world.resource_mut::<EnergyWatch>();
            watch.scale = comm.sum(&[watch.scale])[0];
        }
        let first = outputs.record(sim, true);
        agreed(comm, first)?;
    }
    let mut interrupted = false;
    let mut checkpoint = None;
    // The state at the start of the step, refilled in place each step (no allocation).
    let mut last_good = crate::output::ParticleFrame::default();
    while !sim.finished() {
        if plan.last_good_frame {
            sim.with_world_in_pool(|world| refill_particle_frame(world, &mut last_good));
        }
        // The step the state was at: a rank whose step failed has not moved its clock, the
        // others have.
        let step = sim.clock().step;
        if let Err(failure) = step_once(sim, comm) {
            let settled = outputs.settle();
            let last_good = plan.last_good_frame.then_some(&last_good);
            let written = write_last_good(plan, &frames_dir, step, last_good, comm);
            let written = agreed(comm, settled.and(written))?;
            let listed = outputs.list_every_frame();
            agreed(comm, listed)?;
            return Err(failure.with_last_good(written));
        }
        let recorded = outputs.record(sim, false);
        agreed(comm, recorded)?;
        interrupted = options
            .interrupt
            .is_some_and(|flag| flag.load(Ordering::SeqCst));
        if let Some(comm) = comm {
            // A signal reaches the ranks at different steps: they stop at the first step after
            // any of them saw it.
            interrupted = comm.max(f64::from(u8::from(interrupted))) > 0.0;
        }
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
        steps: clock.step - first_step,
        time: clock.time,
        particles,
        threads: sim.threads(),
        threads_asked: sim.threads_asked(),
        wall: started.elapsed(),
        frames: outputs.frames.len(),
        removed: sim
            .world
            .resource::<fractum_engine::health::EscapedParticles>()
            .count,
        energy_created: sim
            .world
            .get_resource::<EnergyWatch>()
            .and_then(|w| w.worst),
        interrupted,
        never_split: split == Some(false),
        checkpoint,
        ranks: comm.map(|comm| rank_report(sim, comm, clock.step - first_step, sent_before)),
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
    let sums = comm.sum(&[held, owned, sent as f64, nodes as f64, rebuilds as f64]);
    RankReport {
        ranks: comm.size(),
        rebalances,
        imbalance,
        held_over_owned: sums[0] / sums[1].max(1.0),
        sent_per_step: sums[2] / comm.size() as f64 / steps.max(1) as f64,
        held_nodes_over_grid: sums[3] / grid_nodes.max(1) as f64,
        rebuilds: sums[4] as u64,
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

/// The run's outputs and checkpoint schedule: fresh, or continuing a resumed run's (whose
/// series is written back at once).
fn open_outputs<'a>(
    sim: &Simulation,
    plan: &'a OutputPlan,
    out_dir: &'a Path,
    checkpoints: Option<CheckpointPlan>,
    resume: Option<ResumedOutputs>,
    comm: Option<&'a dyn Communicator>,
) -> Result<(Outputs<'a>, CheckpointSchedule), RunError> {
    let mut series = SeriesWriter::new(out_dir.join("series.csv"), &plan.columns());
    if comm.is_some_and(|c| c.rank() != 0) {
        series = series.in_memory();
    }
    let mut outputs = Outputs {
        plan,
        dir: out_dir,
        comm,
        series,
        frames: Vec::new(),
        grid_frames: Vec::new(),
        inherited: [0; 2],
        written: [None; 3],
        writer: FrameWriter::start(plan.compression).map_err(|source| RunError::Io {
            path: out_dir.join("frames"),
            source,
        })?,
    };
    let mut schedule = CheckpointSchedule::new(checkpoints, sim.clock().time);
    if let Some(earlier) = resume {
        outputs.series = SeriesWriter::continuing(out_dir.join("series.csv"), earlier.series);
        if comm.is_some_and(|c| c.rank() != 0) {
            outputs.series = outputs.series.in_memory();
        }
        outputs.frames = earlier.frames;
        outputs.grid_frames = earlier.grid_frames;
        outputs.inherited = [outputs.frames.len(), outputs.grid_frames.len()];
        outputs.written = [Some(sim.clock().step); 3];
        if let Some(t) = earlier.next_checkpoint_time {
            schedule.next_time = Some(t);
        }
        outputs.flush()?;
    }
    Ok((outputs, schedule))
}

/// Writes the state at the start of the failing step, when the plan kept it (every field, for
/// the diagnosis, encoded as the plan says): in a distributed run, each rank's piece and the
/// `.pvtu` index of them, whose path it returns.
fn write_last_good(
    plan: &OutputPlan,
    frames_dir: &Path,
    step: u64,
    last_good: Option<&crate::output::ParticleFrame>,
    comm: Option<&dyn Communicator>,
) -> Result<Option<PathBuf>, RunError> {
    let Some(frame) = last_good else {
        return Ok(None);
    };
    let stem = format!("particles_last_good_{step:08}");
    let Some(comm) = comm else {
        let path = frames_dir.join(format!("{stem}.vtu"));
        write_particle_frame(&path, frame, plan.compression).map_err(io_error(&path))?;
        return Ok(Some(path));
    };
    let index = format!("{stem}.pvtu");
    let pieces: Vec<String> = (0..comm.size()).map(|r| piece_name(&index, r)).collect();
    let writer = index_writer(comm, frame.position.len());
    let piece = frames_dir.join(&pieces[comm.rank()]);
    let arrays = crate::output::particle_frame_file(&piece, frame, plan.compression)
        .map_err(io_error(&piece))?;
    let index = frames_dir.join(index);
    if writer == comm.rank() {
        write_pvtu(&index, &arrays, &pieces).map_err(io_error(&index))?;
    }
    Ok(Some(index))
}

/// Flushes the outputs and writes a checkpoint after the current step, recording what the
/// outputs held then.
fn checkpoint_now(
    sim: &mut Simulation,
    out_dir: &Path,
    options: &RunOptions,
    outputs: &mut Outputs,
    schedule: &CheckpointSchedule,
) -> Result<PathBuf, RunError> {
    let comm = options.communicator;
    let scene = options.scene.as_ref().ok_or_else(|| {
        RunError::Checkpoint("a checkpoint needs the scene's text (RunOptions::scene)".into())
    });
    let scene = agreed(comm, scene)?;
    // The checkpoint lists the frames written: they must be on disk first, on every rank.
    let settled = outputs.settle();
    agreed(comm, settled)?;
    // The collections then name every frame the checkpoint records.
    let listed = outputs.list_every_frame();
    agreed(comm, listed)?;
    let saved = CheckpointOutputs {
        series_bytes: outputs.series.text().len() as u64,
        frames: outputs.frames.clone(),
        grid_frames: outputs.grid_frames.clone(),
        next_checkpoint_time: schedule.next_time,
    };
    let keep = options.checkpoints.map_or(DEFAULT_KEEP, |c| c.keep);
    let Some(comm) = comm else {
        return Ok(write_checkpoint(sim, out_dir, scene, saved, keep)?);
    };
    // Each rank its piece; once all are on disk, rank 0 the manifest that names them, so that
    // a manifest on disk always has its pieces.
    let (rank, ranks) = (comm.rank(), comm.size());
    let piece = write_rank_piece(sim, out_dir, scene, saved.clone(), (rank, ranks));
    let piece = agreed(Some(comm), piece.map_err(RunError::from))?;
    let manifest = if rank == 0 {
        write_rank_manifest(sim, out_dir, scene, saved, ranks, keep).map_err(RunError::from)
    } else {
        Ok(piece)
    };
    agreed(Some(comm), manifest)
}

/// When the next checkpoint is due.
struct CheckpointSchedule {
    every: Option<CheckpointEvery>,
    next_time: Option<f64>,
}

impl CheckpointSchedule {
    fn new(plan: Option<CheckpointPlan>, now: f64) -> Self {
        let every = plan.map(|p| p.every);
        let next_time = match every {
            Some(CheckpointEvery::Time(t)) => Some(now + t),
            _ => None,
        };
        Self { every, next_time }
    }

    /// Whether a checkpoint is due after the step that brought the clock to `clock`; a time
    /// schedule moves on to its next multiple past the clock.
    fn due(&mut self, clock: SimClock) -> bool {
        match self.every {
            Some(CheckpointEvery::Steps(n)) => n > 0 && clock.step.is_multiple_of(n),
            Some(CheckpointEvery::Time(t)) => match self.next_time {
                Some(next) if clock.time >= next => {
                    let mut following = next + t;
                    while following <= clock.time {
                        following += t;
                    }
                    self.next_time = Some(following);
                    true
                }
                _ => false,
            },
            None => false,
        }
    }
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
