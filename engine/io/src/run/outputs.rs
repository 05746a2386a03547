//! The outputs of a run: the series, the particle and grid frames (one piece per rank in a
//! distributed run, with its index), the last good frame, the energy watch and a quasi-static
//! run's kinetic watch.

use super::*;

/// Feeds a series row (time, kinetic, strain, total, …, work, residual) to the world's
/// [`EnergyWatch`] and a quasi-static run's [`KineticWatch`]. The energy watch gets the balance
/// `W_ext − (E − E₀)` left before the damage laws' own `dissipated_energy` accounts:
/// dissipation is never negative, so a total energy above the work done is created energy
/// whatever those accounts say (an account that reads high, as the eigen laws' crack-band
/// estimates can, would otherwise look like creation). The row's whole account, dissipation
/// included, is kept as the world's [`EnergyBalance`] for the end-of-run summary.
/// `initial` is the run's initial energy: in a distributed run the sum of the ranks' parts,
/// not this rank's account's.
pub(super) fn watch_energy(sim: &mut Simulation, row: &[f64], initial: f64) {
    let step = sim.clock().step;
    let n = row.len();
    let (total, work, residual) = (row[3], row[n - 2], row[n - 1]);
    let mut watch = sim.world.get_resource_or_init::<EnergyWatch>();
    watch.observe(step, row[0], total, initial, work, work - (total - initial));
    let scale = watch.scale;
    sim.world.insert_resource(EnergyBalance {
        time: row[0],
        external_work: work,
        energy_change: total - initial,
        dissipated: work - (total - initial) - residual,
        residual,
        scale,
    });
    if let Some(mut kinetic) = sim.world.get_resource_mut::<KineticWatch>() {
        // Kinetic and stored (total less kinetic: strain and contact) energy.
        kinetic.observe(step, row[0], row[1], total - row[1]);
    }
}

pub(super) struct Outputs<'a> {
    pub(super) plan: &'a OutputPlan,
    pub(super) dir: &'a Path,
    /// The ranks of a distributed run, `None` in one process.
    pub(super) comm: Option<&'a dyn Communicator>,
    pub(super) series: SeriesWriter,
    pub(super) frames: Vec<(f64, String)>,
    pub(super) grid_frames: Vec<(f64, String)>,
    /// The particle and grid frames a resumed run began with, written before it.
    pub(super) inherited: [usize; 2],
    /// The step of the last row, particle frame and grid frame written.
    pub(super) written: [Option<u64>; 3],
    /// Encodes and writes the frames while the next steps compute.
    pub(super) writer: FrameWriter,
}

impl Outputs<'_> {
    /// Writes the outputs due at this step, or every output not yet written at this step when
    /// `force` (the end of a run). The series is flushed with every frame, so frames and series
    /// never disagree by more than one output interval.
    pub(super) fn record(&mut self, sim: &mut Simulation, force: bool) -> Result<(), RunError> {
        let result = self.record_unflushed(sim, force);
        if result.is_err() {
            // Keep the rows taken so far: a failed frame write must not lose them too.
            let _ = self.series.flush();
        }
        result
    }

    pub(super) fn record_unflushed(
        &mut self,
        sim: &mut Simulation,
        force: bool,
    ) -> Result<(), RunError> {
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
    pub(super) fn particle_frame(
        &mut self,
        sim: &mut Simulation,
        step: u64,
    ) -> Result<(), RunError> {
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
    pub(super) fn list_frames(&mut self, grid: bool) -> Result<(), RunError> {
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
    pub(super) fn list_every_frame(&mut self) -> Result<(), RunError> {
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
    pub(super) fn grid_frame(&mut self, sim: &mut Simulation, step: u64) -> Result<(), RunError> {
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
    pub(super) fn pieces(
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

    pub(super) fn row(&mut self, sim: &mut Simulation, step: u64) -> Result<(), RunError> {
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

    pub(super) fn flush(&mut self) -> Result<(), RunError> {
        let path = self.dir.join("series.csv");
        self.series.flush().map_err(io_error(&path))
    }

    /// Flushes the series and waits until every frame handed to the writer is on disk.
    pub(super) fn settle(&mut self) -> Result<(), RunError> {
        let series = self.flush();
        self.writer.wait()?;
        series
    }
}

/// The rank that writes the `.pvtu` index of a frame whose piece on this rank holds `count`
/// points: the lowest rank whose piece has points, rank 0 when none has. Every rank calls it.
pub(super) fn index_writer(comm: &dyn Communicator, count: usize) -> usize {
    let counts = comm.all_gather(&[count as f64]);
    counts.iter().position(|&n| n > 0.0).unwrap_or(0)
}

/// The failures of the parts of an output step: one process stops at the first; a rank of a
/// distributed run keeps the first and goes on ([`Outputs::record`]).
pub(super) struct Failures {
    pub(super) distributed: bool,
    pub(super) first: Option<RunError>,
}

impl Failures {
    /// `part`'s failure, for the caller to stop at in one process; kept in a distributed run.
    pub(super) fn keep(&mut self, part: Result<(), RunError>) -> Result<(), RunError> {
        match part {
            Err(e) if self.distributed => {
                self.first.get_or_insert(e);
                Ok(())
            }
            other => other,
        }
    }
}

/// The run's outputs and checkpoint schedule: fresh, or continuing a resumed run's (whose
/// series is written back at once).
pub(super) fn open_outputs<'a>(
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
pub(super) fn write_last_good(
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
