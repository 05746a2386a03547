//! Resuming a run: a checkpoint put into a world freshly built from its scene, and the outputs
//! wound back to it, for [`super::run_with`] to continue.

use super::ResumedOutputs;
use crate::checkpoint::{CheckpointFile, restore};

/// Puts a checkpoint into `sim`, freshly built from the checkpoint's scene, and winds the
/// outputs in `out_dir` back to it: `series.csv` is cut to its rows then, and frames written
/// after it are deleted. Returns the outputs for [`super::run_with`] to continue.
pub fn resume_from(
    sim: &mut fractum_engine::Simulation,
    out_dir: &std::path::Path,
    file: &CheckpointFile,
) -> Result<ResumedOutputs, String> {
    restore_checkpoint(sim, file)?;
    rewind_outputs(out_dir, file, sim.clock().step)
}

/// Puts a checkpoint into `sim`, freshly built from the checkpoint's scene: the world, the
/// clock's compensation and the run's end. The outputs are not touched.
pub fn restore_checkpoint(
    sim: &mut fractum_engine::Simulation,
    file: &CheckpointFile,
) -> Result<(), String> {
    restore(&mut sim.world, &file.world)
        .map_err(|e| format!("the checkpoint does not fit the world built from its scene: {e}"))?;
    sim.set_time_compensation(file.time_compensation);
    sim.set_end(file.end);
    Ok(())
}

/// Winds the outputs in `out_dir` back to checkpoint `file`, taken after `step`: the rows of
/// `series.csv` then (returned, for the run to rewrite), and no frame written after it. Call it
/// only once the run is sure to go on: it deletes those frames.
pub fn rewind_outputs(
    out_dir: &std::path::Path,
    file: &CheckpointFile,
    step: u64,
) -> Result<ResumedOutputs, String> {
    let resumed = resumed_outputs(out_dir, file, step)?;
    remove_later_frames(out_dir, file);
    for (collection, frames) in [
        ("particles.pvd", &file.outputs.frames),
        ("grid.pvd", &file.outputs.grid_frames),
    ] {
        if !frames.is_empty() {
            let path = out_dir.join(collection);
            crate::output::write_pvd(&path, frames)
                .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        }
    }
    Ok(resumed)
}

/// The outputs in `out_dir` as checkpoint `file`, taken after `step`, recorded them, for
/// [`super::run_with`] to continue, without touching a file: what every rank of a resumed
/// distributed run needs, where rank 0 alone winds the files back ([`rewind_outputs`]).
pub fn resumed_outputs(
    out_dir: &std::path::Path,
    file: &CheckpointFile,
    step: u64,
) -> Result<ResumedOutputs, String> {
    let series_path = out_dir.join("series.csv");
    let mut series = std::fs::read_to_string(&series_path)
        .map_err(|e| format!("cannot read {}: {e}", series_path.display()))?;
    let kept = file.outputs.series_bytes as usize;
    if series.len() < kept || !series.is_char_boundary(kept) {
        return Err(format!(
            "{} holds {} bytes, fewer than the {kept} it held at the checkpoint of step {step}; \
             it was changed since",
            series_path.display(),
            series.len()
        ));
    }
    series.truncate(kept);
    Ok(ResumedOutputs {
        series,
        frames: file.outputs.frames.clone(),
        grid_frames: file.outputs.grid_frames.clone(),
        next_checkpoint_time: file.outputs.next_checkpoint_time,
    })
}

/// Deletes the frame files the checkpoint does not list: frames (`.vtu`) and the indexes
/// (`.pvtu`) of a distributed run's frames with their pieces (`<index stem>_<rank>.vtu`).
fn remove_later_frames(out_dir: &std::path::Path, file: &CheckpointFile) {
    let listed: std::collections::HashSet<&str> = file
        .outputs
        .frames
        .iter()
        .chain(&file.outputs.grid_frames)
        .map(|(_, f)| f.as_str())
        .collect();
    let kept = |name: &str| {
        if listed.contains(name) {
            return true;
        }
        // A piece of a listed index.
        let stem = name.strip_suffix(".vtu").unwrap_or(name);
        stem.rsplit_once('_').is_some_and(|(index, rank)| {
            rank.parse::<usize>().is_ok() && listed.contains(format!("{index}.pvtu").as_str())
        })
    };
    let Ok(entries) = std::fs::read_dir(out_dir.join("frames")) else {
        return;
    };
    for entry in entries.flatten() {
        let name = format!("frames/{}", entry.file_name().to_string_lossy());
        let frame = name.ends_with(".vtu") || name.ends_with(".pvtu");
        if frame && !kept(&name) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}
