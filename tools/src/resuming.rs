//! `fractum resume`: the newest checkpoint of an output folder found and read, its scene
//! rebuilt (the one the checkpoint recorded) and its state restored, one process or each rank
//! its piece, and the run continued where it stopped ([`crate::running`] steps it).

use crate::running::{RunSettings, execute, rank_message, ready_to_run};
use crate::{EXIT_BAD_SCENE, EXIT_IO, EXIT_USAGE};
use fractum_engine::communicator::Communicator;
use fractum_engine::registry::Registry;
use fractum_io::checkpoint::{
    CHECKPOINT_DIR, CheckpointFile, RankCheckpoint, list_checkpoints, read_checkpoint,
};
use fractum_io::run::{restore_checkpoint, rewind_outputs};
use fractum_scene::{SceneFile, build_simulation};
use std::path::{Path, PathBuf};

/// The newest checkpoint in `out_dir`, read, with its path; why not, with the exit code.
fn newest_checkpoint(out_dir: &Path) -> Result<(PathBuf, CheckpointFile), (i32, String)> {
    let Some((_, path)) = list_checkpoints(out_dir).pop() else {
        return Err((
            EXIT_IO,
            format!(
                "{} has no checkpoint to resume from (checkpoints are written by `fractum run \
                 --checkpoint-every N`, at its end, and when it is interrupted)",
                out_dir.join(CHECKPOINT_DIR).display()
            ),
        ));
    };
    let checkpoint = read_checkpoint(&path).map_err(|e| (EXIT_IO, e))?;
    Ok((path, checkpoint))
}

/// The ranks the checkpoint's run went over (1 for one process).
fn checkpoint_ranks(checkpoint: &CheckpointFile) -> usize {
    match &checkpoint.ranks {
        Some(RankCheckpoint::Manifest { ranks, .. } | RankCheckpoint::Piece { ranks, .. }) => {
            *ranks
        }
        None => 1,
    }
}

/// Refuses to resume the checkpoint at `path` of a run over `saved` ranks as `ranks`.
fn same_ranks(path: &Path, out_dir: &Path, saved: usize, ranks: usize) -> Result<(), String> {
    if saved == ranks {
        return Ok(());
    }
    let how = if saved == 1 {
        format!("as one process: `fractum resume {}`", out_dir.display())
    } else {
        format!(
            "as {saved} ranks: `mpirun -np {saved} fractum resume {}`",
            out_dir.display()
        )
    };
    Err(format!(
        "{} is the checkpoint of a run over {saved} rank{}, and this resume has {ranks}: each \
         rank holds the particles of its own slab, which another rank count would cut \
         differently. Resume it {how}",
        path.display(),
        if saved == 1 { "" } else { "s" },
    ))
}

/// The scene of `checkpoint` (at `path`), from the copy it holds; refused when the scene file
/// changed since, noted (by `speaks`) when it is gone.
fn checkpoint_scene(
    checkpoint: &CheckpointFile,
    path: &Path,
    speaks: bool,
) -> Result<SceneFile, (i32, String)> {
    let scene_path = Path::new(&checkpoint.scene.path);
    match std::fs::read_to_string(scene_path) {
        Ok(text) if text != checkpoint.scene.text => {
            return Err((
                EXIT_BAD_SCENE,
                format!(
                    "{} changed since the checkpoint {} was written; resuming would mix two \
                     scenes. Restore the scene to continue the run, or start a new run of the \
                     edited scene",
                    scene_path.display(),
                    path.display()
                ),
            ));
        }
        Ok(_) => {}
        Err(_) if speaks => eprintln!(
            "note: {} is gone; resuming from the copy of it in the checkpoint",
            scene_path.display()
        ),
        Err(_) => {}
    }
    SceneFile::parse(&checkpoint.scene.path, checkpoint.scene.text.clone())
        .map_err(|e| (EXIT_BAD_SCENE, e.to_string()))
}

/// A run restored from its newest checkpoint, ready to go on ([`prepare_resume`]).
pub struct Resumed {
    /// The simulation at the checkpoint's step, with the run's threads and step cap.
    pub built: fractum_scene::Built,
    /// The scene the checkpoint keeps, which the resumed run's checkpoints keep too.
    pub scene: fractum_io::checkpoint::SceneRecord,
    /// The outputs rewound to the checkpoint's step.
    pub outputs: fractum_io::run::ResumedOutputs,
    /// The checkpoint resumed from.
    pub checkpoint: PathBuf,
}

/// Restores the run in `out_dir` from its newest checkpoint and makes it ready to step (one
/// process); refused with the exit code and the reason, having changed nothing on disk.
pub fn prepare_resume(
    out_dir: &Path,
    settings: &RunSettings,
    registry: &Registry,
) -> Result<Resumed, (i32, String)> {
    let (path, checkpoint) = newest_checkpoint(out_dir)?;
    same_ranks(&path, out_dir, checkpoint_ranks(&checkpoint), 1).map_err(|e| (EXIT_USAGE, e))?;
    let file = checkpoint_scene(&checkpoint, &path, true)?;
    let mut built =
        build_simulation(&file, registry).map_err(|e| (EXIT_BAD_SCENE, e.to_string()))?;
    restore_checkpoint(&mut built.simulation, &checkpoint)
        .map_err(|e| (EXIT_IO, format!("{}: {e}", path.display())))?;
    ready_to_run(&mut built.simulation, settings, true)?;
    let step = built.simulation.clock().step;
    let outputs = rewind_outputs(out_dir, &checkpoint, step)
        .map_err(|e| (EXIT_IO, format!("{}: {e}", path.display())))?;
    Ok(Resumed {
        built,
        scene: checkpoint.scene.clone(),
        outputs,
        checkpoint: path,
    })
}

/// `fractum resume`: continues the run in `out_dir` from its newest checkpoint.
pub fn resume_command(out_dir: &Path, settings: &RunSettings, registry: &Registry) -> i32 {
    let resumed = match prepare_resume(out_dir, settings, registry) {
        Ok(resumed) => resumed,
        Err((code, message)) => {
            eprintln!("error: {message}");
            return code;
        }
    };
    say_resuming(out_dir, &resumed.built.simulation, &resumed.checkpoint);
    let outputs = Some(resumed.outputs);
    execute(
        resumed.built,
        out_dir,
        resumed.scene,
        outputs,
        settings,
        None,
    )
}

fn say_resuming(out_dir: &Path, sim: &fractum_engine::Simulation, from: &Path) {
    let clock = sim.clock();
    eprintln!(
        "resuming {} at step {}, t = {:e} s, from {}",
        out_dir.display(),
        clock.step,
        clock.time,
        from.display()
    );
}

/// `fractum resume` as one of the ranks of `comm`, from the newest checkpoint of a run over as
/// many ranks: each rank restores its own piece into its part of the scene, rank 0 winds the
/// outputs back, and the ranks go on together ([`run_ranks`](crate::running::run_ranks)).
pub fn resume_ranks(
    out_dir: &Path,
    settings: &RunSettings,
    registry: &Registry,
    comm: &dyn Communicator,
) -> i32 {
    let speaks = comm.rank() == 0;
    let restored = restore_rank(out_dir, settings, registry, comm, speaks);
    let failure = restored.as_ref().err().map(|(_, message)| message.clone());
    if let Err(failure) = comm.agree(failure.as_deref()) {
        // Every rank reads the same manifest and scene: their refusal is every rank's.
        let code = restored.as_ref().err().map_or(EXIT_IO, |(code, _)| *code);
        if speaks {
            eprintln!("error: {}", rank_message(failure));
        }
        return code;
    }
    let Ok((checkpoint, path, built)) = restored else {
        return EXIT_IO;
    };
    // Every rank has read the series before rank 0 winds the outputs back.
    let step = built.simulation.clock().step;
    let outputs = if speaks {
        rewind_outputs(out_dir, &checkpoint, step)
    } else {
        fractum_io::run::resumed_outputs(out_dir, &checkpoint, step)
    };
    let failure = outputs.as_ref().err().cloned();
    if let Err(failure) = comm.agree(failure.as_deref()) {
        if speaks {
            eprintln!("error: {}: {failure}", path.display());
        }
        return EXIT_IO;
    }
    let Ok(outputs) = outputs else {
        return EXIT_IO;
    };
    if speaks {
        say_resuming(out_dir, &built.simulation, &path);
    }
    let mut settings = settings.clone();
    settings.quiet |= !speaks;
    let scene = checkpoint.scene.clone();
    execute(built, out_dir, scene, Some(outputs), &settings, Some(comm))
}

/// This rank's part of the scene of the newest checkpoint in `out_dir`, with its piece of the
/// checkpoint put in and ready to run; the manifest and its path with it.
fn restore_rank(
    out_dir: &Path,
    settings: &RunSettings,
    registry: &Registry,
    comm: &dyn Communicator,
    speaks: bool,
) -> Result<(CheckpointFile, PathBuf, fractum_scene::Built), (i32, String)> {
    let (rank, ranks) = (comm.rank(), comm.size());
    let (path, manifest) = newest_checkpoint(out_dir)?;
    same_ranks(&path, out_dir, checkpoint_ranks(&manifest), ranks).map_err(|e| (EXIT_USAGE, e))?;
    let Some(RankCheckpoint::Manifest { pieces, .. }) = &manifest.ranks else {
        return Err((
            EXIT_IO,
            format!("{} is not a checkpoint manifest", path.display()),
        ));
    };
    let piece_path = path.with_file_name(&pieces[rank]);
    let piece = read_checkpoint(&piece_path).map_err(|e| (EXIT_IO, e))?;
    let file = checkpoint_scene(&manifest, &path, speaks)?;
    let mut built = fractum_scene::build_rank_simulation(&file, registry, rank, ranks)
        .map_err(|e| (EXIT_BAD_SCENE, e.to_string()))?;
    fractum_io::run::distributed::restore_rank_piece(&mut built.simulation, &piece, (rank, ranks))
        .map_err(|e| (EXIT_IO, format!("{}: {e}", piece_path.display())))?;
    ready_to_run(&mut built.simulation, settings, true)?;
    Ok((manifest, path, built))
}
