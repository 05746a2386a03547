//! Checkpoints during a run: when they are due and writing one (a piece per rank and a
//! manifest in a distributed run).

use super::*;

/// Flushes the outputs and writes a checkpoint after the current step, recording what the
/// outputs held then.
pub(super) fn checkpoint_now(
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
pub(super) struct CheckpointSchedule {
    pub(super) every: Option<CheckpointEvery>,
    pub(super) next_time: Option<f64>,
}

impl CheckpointSchedule {
    pub(super) fn new(plan: Option<CheckpointPlan>, now: f64) -> Self {
        let every = plan.map(|p| p.every);
        let next_time = match every {
            Some(CheckpointEvery::Time(t)) => Some(now + t),
            _ => None,
        };
        Self { every, next_time }
    }

    /// Whether a checkpoint is due after the step that brought the clock to `clock`; a time
    /// schedule moves on to its next multiple past the clock.
    pub(super) fn due(&mut self, clock: SimClock) -> bool {
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
