//! The run loop: step to the end, writing frames and time-series rows on schedule.

use crate::boundary::{BoundaryConditions, Reactions};
use crate::checkpoint::{
    CheckpointEvery, CheckpointOutputs, DEFAULT_KEEP, SceneRecord, write_checkpoint,
};
use crate::components::{
    BodyId, Damage, Mass, MaterialId, Node, NodeFields, Particle, ParticleId, Position,
    StrainEnergyDensity, Stress, Velocity, Volume,
};
use crate::diagnostics::{Totals, totals};
use crate::dim::{Dim, Dimension, SymOps, VectorOps};
use crate::energy::EnergyWatch;
use crate::health::Blowup;
use crate::output::{
    GridFrame, OutputPlan, ParticleFrame, ProbeKind, SeriesWriter, write_grid_frame,
    write_particle_frame, write_pvd,
};
use crate::resources::{SimClock, Thickness};
use crate::simulation::Simulation;
use crate::with_dim;
use bevy_ecs::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Why a run did not finish.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The state became invalid. Outputs up to the previous output step are on disk, and the
    /// state at the start of the failing step too when the plan keeps it.
    #[error("the run stopped at {0}")]
    Blowup(Blowup, Option<PathBuf>),
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
    pub energy_created: Option<crate::energy::EnergyCreation>,
    /// Whether the run stopped early on [`RunOptions::interrupt`].
    pub interrupted: bool,
    /// The last checkpoint written, if any.
    pub checkpoint: Option<PathBuf>,
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

/// Collects the particle state for a VTU frame (the world's [`Dimension`] says which
/// components it has).
pub fn particle_frame(world: &mut World) -> ParticleFrame {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => particle_frame_of::<D>(world))
}

fn particle_frame_of<D: Dim>(world: &mut World) -> ParticleFrame {
    let mut query = world.query_filtered::<(
        &ParticleId,
        &BodyId,
        &MaterialId,
        &Position<D>,
        &Velocity<D>,
        &Mass,
        &Volume,
        &Stress<D>,
        &Damage,
        &StrainEnergyDensity,
    ), With<Particle>>();
    let mut f = ParticleFrame::default();
    for (id, body, material, x, v, m, vol, s, d, w) in query.iter(world) {
        f.id.push(id.0);
        f.body.push(body.0);
        f.material.push(material.0);
        f.position.push(x.0.to_3d());
        f.velocity.push(v.0.to_3d());
        f.mass.push(m.0);
        f.volume.push(vol.0);
        f.stress.push(s.0.as_3x3());
        f.damage.push(d.0);
        f.strain_energy_density.push(w.0);
    }
    system_columns::<D>(world, &mut f);
    if D::N == 2 {
        f.thickness = world.get_resource::<Thickness>().map(|t| t.0);
    }
    f
}

/// The grid nodes that carry mass, with each velocity field's key, mass, velocity and normal.
pub fn grid_frame(world: &mut World) -> GridFrame {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => grid_frame_of::<D>(world))
}

fn grid_frame_of<D: Dim>(world: &mut World) -> GridFrame {
    let grid = world.resource::<crate::resources::Grid<D>>().clone();
    let mut query = world.query_filtered::<(
        &crate::components::NodeIndex,
        &NodeFields,
        &crate::components::NodeMass,
        &crate::components::NodeVelocity<D>,
        &crate::components::NodeNormal<D>,
    ), With<Node>>();
    let mut f = GridFrame::default();
    for (index, fields, mass, velocity, normal) in query.iter(world) {
        if mass.0.iter().sum::<f64>() <= 0.0 {
            continue;
        }
        f.index.push(index.0);
        f.position
            .push(grid.node_position(index.0 as usize).to_3d());
        f.fields.push(fields.count);
        f.key.push(std::array::from_fn(|k| {
            if k < usize::from(fields.count) {
                i32::from(fields.keys[k].0)
            } else {
                -1
            }
        }));
        f.mass.push(mass.0);
        f.velocity.push(velocity.0.map(|v| v.to_3d()));
        f.normal.push(normal.0.map(|v| v.to_3d()));
    }
    f
}

/// The columns the installed systems registered ([`crate::output::FrameColumns`]), then the
/// velocity field of each particle at its nearest node (the key `2 × group + side` of the field
/// its largest-weight node puts it in) when some system assigns fields.
fn system_columns<D: Dim>(world: &mut World, f: &mut ParticleFrame) {
    if let Some(columns) = world.get_resource::<crate::output::FrameColumns>().cloned() {
        for (name, values) in columns.read(world) {
            match values {
                crate::output::ColumnValues::Scalar(v) => f.scalars.push((name, v)),
                crate::output::ColumnValues::Vector(v) => f.vectors.push((name, v)),
            }
        }
    }
    if !world.contains_resource::<crate::fields::FieldsAssigned>() {
        return;
    }
    let mut nodes = world.query_filtered::<&NodeFields, With<Node>>();
    let node_fields: Vec<NodeFields> = nodes.iter(world).copied().collect();
    let c = world.resource::<crate::connectivity::Connectivity<D>>();
    if c.row_offsets.len() != f.id.len() + 1 {
        return;
    }
    let field = (0..f.id.len())
        .map(|p| {
            c.row(p)
                .max_by(|&a, &b| c.weights[a].total_cmp(&c.weights[b]).then(b.cmp(&a)))
                .map_or(f64::NAN, |e| {
                    f64::from(node_fields[c.nodes[e] as usize].keys[c.field(e)].0)
                })
        })
        .collect();
    f.scalars.push(("velocity_field".into(), field));
}

/// The values of one `series.csv` row after the step column.
pub fn series_row(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    with_dim!(plan.dimension, D => series_row_of::<D>(world, plan))
}

/// The value of one probe, one entry per axis.
fn probe_value<D: Dim>(
    world: &mut World,
    slot: usize,
    probe: &ProbeKind,
    totals: &Totals,
) -> D::Vector {
    let time = world.resource::<SimClock>().time;
    match probe {
        ProbeKind::Reaction { index, .. } => world
            .resource::<Reactions<D>>()
            .0
            .get(*index)
            .copied()
            .unwrap_or_default(),
        ProbeKind::CentreOfMassVelocity => {
            let v = totals.centre_of_mass_velocity();
            D::Vector::from_fn(|a| v[a])
        }
        ProbeKind::Force { index, .. } => {
            let mut query =
                world.query_filtered::<(&BodyId, &Mass, &Velocity<D>), With<Particle>>();
            let momentum = query
                .iter(world)
                .filter(|(b, _, _)| b.0 == *index)
                .fold(D::Vector::ZERO, |p, (_, m, v)| p + v.0 * m.0);
            let mut memory = world.get_resource_or_init::<ForceProbeMemory>();
            memory
                .mean_force(
                    slot,
                    time,
                    std::array::from_fn(|a| if a < D::N { momentum[a] } else { 0.0 }),
                )
                .map_or(D::Vector::ZERO, |f| D::Vector::from_fn(|a| f[a]))
        }
        ProbeKind::Track {
            particle,
            reference,
            ..
        } => {
            let displacement = |tracked: &Option<(Entity, [f64; 3])>| -> D::Vector {
                let at = tracked.and_then(|(p, origin)| {
                    world
                        .get::<Position<D>>(p)
                        .map(|x| D::Vector::from_fn(|a| x.0[a] - origin[a]))
                });
                at.unwrap_or(D::Vector::splat(f64::NAN))
            };
            let moved = displacement(particle);
            match reference {
                Some(_) => moved - displacement(reference),
                None => moved,
            }
        }
        ProbeKind::Displacement { index, .. } => {
            let region = &world.resource::<BoundaryConditions>().regions[*index];
            D::Vector::from_fn(|a| {
                region.velocity[a]
                    .as_ref()
                    .map_or(0.0, |f| f.integral(time))
            })
        }
    }
}

/// The particle with the largest kinetic energy (or the first whose energy is not finite), for
/// a message about energy that overflowed.
fn largest_energy_particle(world: &mut World) -> String {
    let dimension = *world.resource::<Dimension>();
    with_dim!(dimension, D => {
        let mut query =
            world.query_filtered::<(&ParticleId, &Mass, &Velocity<D>), With<Particle>>();
        let worst = query
            .iter(world)
            .map(|(id, m, v)| (id.0, 0.5 * m.0 * v.0.dot(v.0), v.0.to_3d()))
            .max_by(|a, b| {
                let key = |e: f64| if e.is_finite() { e } else { f64::INFINITY };
                key(a.1).total_cmp(&key(b.1))
            });
        match worst {
            Some((id, energy, v)) => format!(
                "particle {id} has velocity {:?} m/s and kinetic energy {energy:e} J",
                &v[..D::N]
            ),
            None => "no particle is left".to_string(),
        }
    })
}

/// Whether entry `i` of a series row (time first) must be finite: all but a `Track` probe's,
/// which is NaN by design once its particle has left the grid.
fn must_be_finite(plan: &OutputPlan, i: usize) -> bool {
    let axes = plan.dimension.count();
    let probes_start = 4 + axes;
    match i.checked_sub(probes_start).map(|k| k / axes) {
        Some(probe) if probe < plan.probes.len() => {
            !matches!(plan.probes[probe], ProbeKind::Track { .. })
        }
        _ => true,
    }
}

/// What the `Force` probes remember between series rows, per probe slot.
#[derive(Resource, Default, Debug, serde::Serialize, serde::Deserialize)]
pub struct ForceProbeMemory(Vec<Option<ForceProbeRow>>);

/// One `Force` probe's last row.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct ForceProbeRow {
    time: f64,
    momentum: [f64; 3],
    reported: Option<[f64; 3]>,
}

impl ForceProbeMemory {
    /// The mean net force `(P − P₀)/(t − t₀)` on a body over the interval since the previous
    /// row, from its momentum `P` now; `None` at the first row (no interval yet, reported as
    /// zero). A second row at the same time repeats the first row's value.
    pub fn mean_force(&mut self, slot: usize, time: f64, momentum: [f64; 3]) -> Option<[f64; 3]> {
        if self.0.len() <= slot {
            self.0.resize(slot + 1, None);
        }
        let force = match self.0[slot] {
            Some(row) if row.time == time => return row.reported,
            Some(row) => Some(std::array::from_fn(|a| {
                (momentum[a] - row.momentum[a]) / (time - row.time)
            })),
            None => None,
        };
        self.0[slot] = Some(ForceProbeRow {
            time,
            momentum,
            reported: force,
        });
        force
    }
}

fn series_row_of<D: Dim>(world: &mut World, plan: &OutputPlan) -> Vec<f64> {
    let t = totals(world);
    let time = world.resource::<SimClock>().time;
    let mut row = vec![time, t.kinetic_energy, t.strain_energy, t.total_energy()];
    row.extend_from_slice(&t.momentum[..D::N]);
    for (slot, probe) in plan.probes.iter().enumerate() {
        let value = probe_value::<D>(world, slot, probe, &t);
        row.extend((0..D::N).map(|a| value[a]));
    }
    let mut dissipated = 0.0;
    if let Some(extra) = world.get_resource::<crate::series::SeriesColumns>() {
        row.extend(
            plan.system_columns
                .iter()
                .map(|name| extra.value(name).unwrap_or(f64::NAN)),
        );
        dissipated = extra.value("dissipated_energy").unwrap_or(0.0);
    }
    let (work, initial) = world
        .get_resource::<crate::energy::EnergyAccount>()
        .map_or((f64::NAN, f64::NAN), |a| {
            (a.external_work, a.initial_energy)
        });
    row.push(work);
    row.push(work - (t.total_energy() - initial) - dissipated);
    row
}

/// Feeds a series row (time, kinetic, strain, total, …, work, residual) to the world's
/// [`EnergyWatch`], with the balance `W_ext − (E − E₀)` left before the damage laws' own
/// `dissipated_energy` accounts: dissipation is never negative, so a total energy above the
/// work done is created energy whatever those accounts say (the uniaxial account of the
/// Rankine laws reads up to 25% high, which alone would look like creation).
fn watch_energy(sim: &mut Simulation, row: &[f64]) {
    let step = sim.clock().step;
    let initial = sim
        .world
        .get_resource::<crate::energy::EnergyAccount>()
        .map_or(f64::NAN, |a| a.initial_energy);
    let n = row.len();
    let (total, work) = (row[3], row[n - 2]);
    let mut watch = sim.world.get_resource_or_init::<EnergyWatch>();
    watch.observe(step, row[0], total, initial, work, work - (total - initial));
}

struct Outputs<'a> {
    plan: &'a OutputPlan,
    dir: &'a Path,
    series: SeriesWriter,
    frames: Vec<(f64, String)>,
    grid_frames: Vec<(f64, String)>,
    /// The step of the last row, particle frame and grid frame written.
    written: [Option<u64>; 3],
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
        let row_due = due(self.plan.csv_every) || (self.plan.csv_every == 0 && step == 0);
        if (force || row_due) && fresh(self.written[0]) {
            self.written[0] = Some(step);
            self.row(sim, step)?;
        }
        let mut framed = false;
        if self.plan.vtu_every > 0 && (force || due(self.plan.vtu_every)) && fresh(self.written[1])
        {
            self.written[1] = Some(step);
            let name = format!("frames/particles_{step:08}.vtu");
            let path = self.dir.join(&name);
            write_particle_frame(&path, &particle_frame(&mut sim.world))
                .map_err(io_error(&path))?;
            self.frames.push((sim.clock().time, name));
            let pvd = self.dir.join("particles.pvd");
            write_pvd(&pvd, &self.frames).map_err(io_error(&pvd))?;
            framed = true;
        }
        if self.plan.grid_every > 0
            && (force || due(self.plan.grid_every))
            && fresh(self.written[2])
        {
            self.written[2] = Some(step);
            let name = format!("frames/grid_{step:08}.vtu");
            let path = self.dir.join(&name);
            write_grid_frame(&path, &grid_frame(&mut sim.world)).map_err(io_error(&path))?;
            self.grid_frames.push((sim.clock().time, name));
            let pvd = self.dir.join("grid.pvd");
            write_pvd(&pvd, &self.grid_frames).map_err(io_error(&pvd))?;
            framed = true;
        }
        if framed {
            self.flush()?;
        }
        Ok(())
    }

    fn row(&mut self, sim: &mut Simulation, step: u64) -> Result<(), RunError> {
        let row = series_row(&mut sim.world, self.plan);
        // Energies and momentum of finite states can still overflow (speeds near 1e200), and a
        // probe or a system's column can still divide by a vanishing quantity: a row holding
        // either is no result. The stage checks have passed, so every particle is finite; the
        // most energetic one is named to place the overflow.
        let broken = (0..row.len()).find(|&i| !row[i].is_finite() && must_be_finite(self.plan, i));
        if let Some(column) = broken {
            self.flush()?;
            let name = &self.plan.columns()[column + 1];
            return Err(RunError::Blowup(
                Blowup::new(
                    step,
                    crate::stage::Stage::PostStep,
                    format!(
                        "the series column {name} is {} after the step: {}",
                        row[column],
                        largest_energy_particle(&mut sim.world)
                    ),
                ),
                None,
            ));
        }
        watch_energy(sim, &row);
        let path = self.dir.join("series.csv");
        self.series.push(step, &row).map_err(io_error(&path))
    }

    fn flush(&mut self) -> Result<(), RunError> {
        let path = self.dir.join("series.csv");
        self.series.flush().map_err(io_error(&path))
    }
}

/// What a run does besides stepping: checkpoints, interruption, and continuing the outputs
/// of an earlier run.
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
    let frames_dir = out_dir.join("frames");
    std::fs::create_dir_all(&frames_dir).map_err(io_error(&frames_dir))?;
    remove_stale_temporaries(out_dir);
    let resumed = options.resume.is_some();
    let mut outputs = Outputs {
        plan,
        dir: out_dir,
        series: SeriesWriter::new(out_dir.join("series.csv"), &plan.columns()),
        frames: Vec::new(),
        grid_frames: Vec::new(),
        written: [None; 3],
    };
    let mut schedule = CheckpointSchedule::new(options.checkpoints, sim.clock().time);
    if let Some(earlier) = options.resume {
        outputs.series = SeriesWriter::continuing(out_dir.join("series.csv"), earlier.series);
        outputs.frames = earlier.frames;
        outputs.grid_frames = earlier.grid_frames;
        outputs.written = [Some(sim.clock().step); 3];
        if let Some(t) = earlier.next_checkpoint_time {
            schedule.next_time = Some(t);
        }
        outputs.flush()?;
    }
    let particles = sim.particle_count();
    let started = Instant::now();
    let first_step = sim.clock().step;
    if !resumed {
        outputs.record(sim, true)?;
    }
    let mut interrupted = false;
    let mut checkpoint = None;
    while !sim.finished() {
        let last_good = plan.last_good_frame.then(|| particle_frame(&mut sim.world));
        if let Err(blowup) = sim.step() {
            outputs.flush()?;
            let written = match last_good {
                Some(frame) => {
                    let step = sim.clock().step;
                    let path = frames_dir.join(format!("particles_last_good_{step:08}.vtu"));
                    write_particle_frame(&path, &frame).map_err(io_error(&path))?;
                    Some(path)
                }
                None => None,
            };
            return Err(RunError::Blowup(blowup, written));
        }
        outputs.record(sim, false)?;
        interrupted = options
            .interrupt
            .is_some_and(|flag| flag.load(Ordering::SeqCst));
        let last = sim.finished() || interrupted;
        let wanted = options.checkpoints.is_some() || interrupted;
        if wanted && (schedule.due(sim.clock()) || last) {
            let scene = options.scene.as_ref().ok_or_else(|| {
                RunError::Checkpoint(
                    "a checkpoint needs the scene's text (RunOptions::scene)".into(),
                )
            })?;
            outputs.flush()?;
            let saved = CheckpointOutputs {
                series_bytes: outputs.series.text().len() as u64,
                frames: outputs.frames.clone(),
                grid_frames: outputs.grid_frames.clone(),
                next_checkpoint_time: schedule.next_time,
            };
            let keep = options.checkpoints.map_or(DEFAULT_KEEP, |c| c.keep);
            checkpoint = Some(write_checkpoint(sim, out_dir, scene, saved, keep)?);
        }
        if last {
            outputs.record(sim, true)?;
        }
        on_step(sim);
        if interrupted {
            break;
        }
    }
    outputs.flush()?;
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
            .resource::<crate::health::EscapedParticles>()
            .count,
        energy_created: sim
            .world
            .get_resource::<EnergyWatch>()
            .and_then(|w| w.worst),
        interrupted,
        checkpoint,
    })
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The force probe reports the mean force over each interval between rows, nothing at the
    /// first row, and repeats itself when asked twice at one time.
    #[test]
    fn force_probes_report_the_momentum_rate_between_rows() {
        let mut memory = ForceProbeMemory::default();
        assert_eq!(memory.mean_force(1, 0.0, [1.0, 2.0, 0.0]), None);
        let force = memory.mean_force(1, 0.5, [2.0, 1.0, 0.0]).unwrap();
        assert_eq!(force, [2.0, -2.0, 0.0]);
        assert_eq!(memory.mean_force(1, 0.5, [9.0, 9.0, 9.0]), Some(force));
        assert_eq!(
            memory.mean_force(1, 1.5, [3.0, 1.0, 0.0]),
            Some([1.0, 0.0, 0.0])
        );
        assert_eq!(memory.mean_force(0, 1.5, [3.0, 1.0, 0.0]), None);
    }
}
