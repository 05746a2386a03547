//! Checkpoint files: the format, its digest, names, and writing and reading them.
//!
//! What a checkpoint carries (the state of a world, captured and restored) is the core's
//! ([`fractum_engine::checkpoint`]), re-exported here so that one module names all of it.

pub use fractum_engine::checkpoint::*;

use serde::{Deserialize, Serialize};

/// The format of checkpoint files; a file of another format is refused. Format 3: the
/// postcard-encoded [`CheckpointFile`], then the FNV-1a digest of those bytes (8 bytes, little
/// endian), so that a damaged file is refused, not resumed with altered numbers. (Format 3
/// added [`CheckpointFile::ranks`].)
pub const CHECKPOINT_FORMAT: u32 = 3;

/// Checkpoints kept by default.
pub const DEFAULT_KEEP: usize = 3;

/// The folder of an output folder that holds its checkpoints.
pub const CHECKPOINT_DIR: &str = "checkpoints";

/// How often checkpoints are written.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum CheckpointEvery {
    /// Every so many steps.
    Steps(u64),
    /// Every so much simulated time (s).
    Time(f64),
}

impl std::str::FromStr for CheckpointEvery {
    type Err = String;

    /// `1000` (steps) or `2.5e-5s` (simulated seconds).
    fn from_str(text: &str) -> Result<Self, String> {
        let text = text.trim();
        if let Some(seconds) = text.strip_suffix('s') {
            return match seconds.trim().parse::<f64>() {
                Ok(t) if t.is_finite() && t > 0.0 => Ok(CheckpointEvery::Time(t)),
                _ => Err(format!(
                    "`{text}`: expected a positive time in seconds such as `2.5e-5s`"
                )),
            };
        }
        match text.parse::<u64>() {
            Ok(n) if n > 0 => Ok(CheckpointEvery::Steps(n)),
            _ => Err(format!(
                "`{text}`: expected a number of steps such as `1000`, or a time such as `2.5e-5s`"
            )),
        }
    }
}

/// The scene a run was built from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneRecord {
    /// The scene file as given on the command line, made absolute where possible.
    pub path: String,
    /// Its text.
    pub text: String,
}

impl SceneRecord {
    /// A 64-bit FNV-1a digest of the text (to tell whether a file changed).
    pub fn digest(&self) -> u64 {
        fnv1a(self.text.as_bytes())
    }
}

/// What the outputs held at a checkpoint.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointOutputs {
    /// The length of `series.csv` then (bytes).
    pub series_bytes: u64,
    /// Particle frames written by then: (time, file relative to the output folder).
    pub frames: Vec<(f64, String)>,
    /// Grid frames written by then.
    pub grid_frames: Vec<(f64, String)>,
    /// The simulated time of the next checkpoint on a time schedule.
    pub next_checkpoint_time: Option<f64>,
}

/// One checkpoint file: who wrote it, from which scene, and everything the run needs to
/// continue.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointFile {
    /// [`CHECKPOINT_FORMAT`] when written.
    pub format: u32,
    /// The Fractum version that wrote it.
    pub version: String,
    /// A digest of the executable that wrote it ([`binary_identity`]).
    pub binary: u64,
    /// The scene.
    pub scene: SceneRecord,
    /// The run's end (the scene's, or `--steps`).
    pub end: fractum_engine::simulation::End,
    /// The clock's running-sum compensation.
    pub time_compensation: f64,
    /// The world.
    pub world: WorldState,
    /// The outputs.
    pub outputs: CheckpointOutputs,
    /// Where the run went over several ranks: this file's part of the checkpoint.
    pub ranks: Option<RankCheckpoint>,
}

/// The parts of the checkpoint of a run over several ranks. Each rank writes its own state
/// ([`RankCheckpoint::Piece`], `checkpoint_<step>.rank<r>.bin`); once every rank has, rank 0
/// writes the manifest ([`RankCheckpoint::Manifest`], `checkpoint_<step>.bin`, the name
/// [`list_checkpoints`] finds), with the outputs and an empty world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum RankCheckpoint {
    /// The checkpoint's pieces, one per rank in rank order, as file names in its folder.
    Manifest {
        /// The ranks of the run.
        ranks: usize,
        /// Each rank's piece.
        pieces: Vec<String>,
    },
    /// One rank's state.
    Piece {
        /// The rank.
        rank: usize,
        /// The ranks of the run.
        ranks: usize,
        /// What the rank held and owned ([`fractum_engine::decomposition::Ownership`]), postcard-encoded.
        ownership: Vec<u8>,
    },
}

/// The file name of rank `rank`'s piece of the checkpoint after `step` (not matched by
/// [`list_checkpoints`], which lists the manifests).
pub fn rank_checkpoint_name(step: u64, rank: usize) -> String {
    format!("checkpoint_{step:012}.rank{rank}.bin")
}

fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |hash, &b| {
        (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
    })
}

/// A digest of the running executable's bytes (0 where it cannot be read): two builds that
/// differ in any way, even one that would round a sum differently, differ here.
pub fn binary_identity() -> u64 {
    static IDENTITY: std::sync::OnceLock<u64> = std::sync::OnceLock::new();
    *IDENTITY.get_or_init(|| {
        std::env::current_exe()
            .and_then(std::fs::read)
            .map_or(0, |bytes| fnv1a(&bytes))
    })
}

/// The file name of the checkpoint after `step`: never matched by `*.csv` or `*.vtu`.
pub fn checkpoint_name(step: u64) -> String {
    format!("checkpoint_{step:012}.bin")
}

/// The step a checkpoint file name is for.
fn step_of_name(name: &str) -> Option<u64> {
    name.strip_prefix("checkpoint_")?
        .strip_suffix(".bin")?
        .parse()
        .ok()
}

/// The checkpoints in `out_dir`, oldest first.
pub fn list_checkpoints(out_dir: &std::path::Path) -> Vec<(u64, std::path::PathBuf)> {
    let dir = out_dir.join(CHECKPOINT_DIR);
    let mut found: Vec<(u64, std::path::PathBuf)> = std::fs::read_dir(&dir)
        .map(|entries| {
            entries
                .flatten()
                .filter_map(|e| {
                    let step = step_of_name(&e.file_name().to_string_lossy())?;
                    Some((step, e.path()))
                })
                .collect()
        })
        .unwrap_or_default();
    found.sort();
    found
}

/// Why a checkpoint could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// The state could not be encoded.
    #[error("{0}")]
    Encode(String),
    /// The file could not be written.
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Writes the checkpoint of `sim` after its current step into `out_dir/checkpoints`
/// atomically, and deletes all but the newest `keep`. Returns its path.
pub fn write_checkpoint(
    sim: &mut fractum_engine::Simulation,
    out_dir: &std::path::Path,
    scene: &SceneRecord,
    outputs: CheckpointOutputs,
    keep: usize,
) -> Result<std::path::PathBuf, WriteError> {
    let world = capture(&mut sim.world).map_err(|e| WriteError::Encode(e.to_string()))?;
    let file = checkpoint_file(sim, scene, outputs, world, None);
    let path = checkpoint_path(out_dir, &checkpoint_name(sim.clock().step))?;
    write_sealed(&path, &file)?;
    prune_checkpoints(out_dir, keep);
    Ok(path)
}

/// Writes this rank's piece of the checkpoint of a run over `ranks` ranks after the current
/// step, with what it owns (`ownership`). Returns its path. The run writes the manifest
/// ([`write_rank_manifest`]) once every rank has written its piece.
pub fn write_rank_piece(
    sim: &mut fractum_engine::Simulation,
    out_dir: &std::path::Path,
    scene: &SceneRecord,
    outputs: CheckpointOutputs,
    (rank, ranks): (usize, usize),
) -> Result<std::path::PathBuf, WriteError> {
    let ownership = sim
        .world
        .get_resource::<fractum_engine::decomposition::Ownership>()
        .ok_or_else(|| WriteError::Encode("a rank's checkpoint needs its Ownership".into()))?;
    let ownership =
        postcard::to_allocvec(ownership).map_err(|e| WriteError::Encode(e.to_string()))?;
    let piece = RankCheckpoint::Piece {
        rank,
        ranks,
        ownership,
    };
    let world = capture(&mut sim.world).map_err(|e| WriteError::Encode(e.to_string()))?;
    let file = checkpoint_file(sim, scene, outputs, world, Some(piece));
    let path = checkpoint_path(out_dir, &rank_checkpoint_name(sim.clock().step, rank))?;
    write_sealed(&path, &file)?;
    Ok(path)
}

/// Writes the manifest of the checkpoint of a run over `ranks` ranks after the current step,
/// once every rank has written its piece ([`write_rank_piece`]), and deletes all but the newest
/// `keep` checkpoints with their pieces. Returns its path.
pub fn write_rank_manifest(
    sim: &fractum_engine::Simulation,
    out_dir: &std::path::Path,
    scene: &SceneRecord,
    outputs: CheckpointOutputs,
    ranks: usize,
    keep: usize,
) -> Result<std::path::PathBuf, WriteError> {
    let step = sim.clock().step;
    let manifest = RankCheckpoint::Manifest {
        ranks,
        pieces: (0..ranks).map(|r| rank_checkpoint_name(step, r)).collect(),
    };
    let file = checkpoint_file(sim, scene, outputs, WorldState::default(), Some(manifest));
    let path = checkpoint_path(out_dir, &checkpoint_name(step))?;
    write_sealed(&path, &file)?;
    prune_checkpoints(out_dir, keep);
    Ok(path)
}

/// A checkpoint of `sim` with `world` as its state.
fn checkpoint_file(
    sim: &fractum_engine::Simulation,
    scene: &SceneRecord,
    outputs: CheckpointOutputs,
    world: WorldState,
    ranks: Option<RankCheckpoint>,
) -> CheckpointFile {
    CheckpointFile {
        format: CHECKPOINT_FORMAT,
        version: env!("CARGO_PKG_VERSION").to_string(),
        binary: binary_identity(),
        scene: scene.clone(),
        end: sim.end(),
        time_compensation: sim.time_compensation(),
        world,
        outputs,
        ranks,
    }
}

/// `out_dir/checkpoints/name`, the folder made.
fn checkpoint_path(
    out_dir: &std::path::Path,
    name: &str,
) -> Result<std::path::PathBuf, WriteError> {
    let dir = out_dir.join(CHECKPOINT_DIR);
    std::fs::create_dir_all(&dir).map_err(|source| WriteError::Io {
        path: dir.clone(),
        source,
    })?;
    Ok(dir.join(name))
}

/// Writes `file`, sealed with its digest, to `path` atomically.
fn write_sealed(path: &std::path::Path, file: &CheckpointFile) -> Result<(), WriteError> {
    let bytes = sealed(postcard::to_allocvec(file).map_err(|e| WriteError::Encode(e.to_string()))?);
    crate::output::write_atomically(path, &bytes).map_err(|source| WriteError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Deletes all but the newest `keep` checkpoints in `out_dir`, and the ranks' pieces of those
/// deleted.
fn prune_checkpoints(out_dir: &std::path::Path, keep: usize) {
    let all = list_checkpoints(out_dir);
    let stale: Vec<u64> = (all.iter().take(all.len().saturating_sub(keep.max(1))))
        .map(|(step, old)| {
            let _ = std::fs::remove_file(old);
            *step
        })
        .collect();
    let Ok(entries) = std::fs::read_dir(out_dir.join(CHECKPOINT_DIR)) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let piece_of = name
            .to_string_lossy()
            .strip_prefix("checkpoint_")
            .and_then(|rest| rest.split_once(".rank"))
            .and_then(|(step, _)| step.parse::<u64>().ok());
        if piece_of.is_some_and(|step| stale.contains(&step)) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// `payload` followed by its digest.
fn sealed(mut payload: Vec<u8>) -> Vec<u8> {
    let digest = fnv1a(&payload);
    payload.extend_from_slice(&digest.to_le_bytes());
    payload
}

/// The payload of sealed `bytes`, or `None` when the digest does not match (the file was cut
/// short, or any byte of it changed).
fn unsealed(bytes: &[u8]) -> Option<&[u8]> {
    let (payload, digest) = bytes.split_at_checked(bytes.len().checked_sub(8)?)?;
    (fnv1a(payload).to_le_bytes() == digest).then_some(payload)
}

/// Reads a checkpoint file and checks that it is whole and that this binary wrote it.
pub fn read_checkpoint(path: &std::path::Path) -> Result<CheckpointFile, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let Some(payload) = unsealed(&bytes) else {
        return Err(format!(
            "{} is damaged or not a checkpoint this version of Fractum can read: its digest \
             does not match its contents (cut short, or changed since it was written)",
            path.display()
        ));
    };
    let file: CheckpointFile = postcard::from_bytes(payload).map_err(|e| {
        format!(
            "{} is not a checkpoint this version of Fractum can read ({e})",
            path.display()
        )
    })?;
    if file.format != CHECKPOINT_FORMAT || file.version != env!("CARGO_PKG_VERSION") {
        return Err(format!(
            "{} was written by Fractum {} (checkpoint format {}), this is {} (format {}); \
             resume it with the binary that wrote it",
            path.display(),
            file.version,
            file.format,
            env!("CARGO_PKG_VERSION"),
            CHECKPOINT_FORMAT
        ));
    }
    if file.binary != binary_identity() {
        return Err(format!(
            "{} was written by another build of Fractum {} (executable digest {:016x}, this one \
             {:016x}); a different build can round differently, so the run would not continue \
             as it began. Resume it with the binary that wrote it, or start the run again",
            path.display(),
            file.version,
            file.binary,
            binary_identity()
        ));
    }
    Ok(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checkpoint_schedules_read_as_steps_or_seconds() {
        assert_eq!("1000".parse(), Ok(CheckpointEvery::Steps(1000)));
        assert_eq!("2.5e-5s".parse(), Ok(CheckpointEvery::Time(2.5e-5)));
        assert!("0".parse::<CheckpointEvery>().is_err());
        assert!("-1s".parse::<CheckpointEvery>().is_err());
        assert!("often".parse::<CheckpointEvery>().is_err());
    }

    fn checkpoint_of(binary: u64, version: &str) -> CheckpointFile {
        CheckpointFile {
            format: CHECKPOINT_FORMAT,
            version: version.to_string(),
            binary,
            scene: SceneRecord {
                path: "scene.ron".into(),
                text: "()".into(),
            },
            end: fractum_engine::simulation::End::Steps(10),
            time_compensation: 0.0,
            world: WorldState::default(),
            outputs: CheckpointOutputs {
                series_bytes: 0,
                frames: Vec::new(),
                grid_frames: Vec::new(),
                next_checkpoint_time: None,
            },
            ranks: None,
        }
    }

    /// A checkpoint reads back as written from this binary, and is refused with the reason
    /// when another build or version wrote it, or when it is cut short.
    #[test]
    fn checkpoints_of_another_build_or_damaged_are_refused() {
        let dir = std::env::temp_dir().join(format!("fractum-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(checkpoint_name(10));
        let write = |file: &CheckpointFile| {
            std::fs::write(&path, sealed(postcard::to_allocvec(file).unwrap())).unwrap();
        };
        let ours = checkpoint_of(binary_identity(), env!("CARGO_PKG_VERSION"));
        write(&ours);
        assert_eq!(read_checkpoint(&path).unwrap(), ours);
        write(&checkpoint_of(
            binary_identity() ^ 1,
            env!("CARGO_PKG_VERSION"),
        ));
        let refused = read_checkpoint(&path).unwrap_err();
        assert!(refused.contains("another build"), "{refused}");
        write(&checkpoint_of(binary_identity(), "0.0.1"));
        let refused = read_checkpoint(&path).unwrap_err();
        assert!(refused.contains("written by Fractum 0.0.1"), "{refused}");
        let bytes = sealed(postcard::to_allocvec(&ours).unwrap());
        std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
        let refused = read_checkpoint(&path).unwrap_err();
        assert!(refused.contains("is damaged"), "{refused}");
        // One bit flipped anywhere, in a number the decoder would have taken as it is.
        for at in [0, 1, bytes.len() / 3, bytes.len() - 9, bytes.len() - 1] {
            let mut flipped = bytes.clone();
            flipped[at] ^= 0x10;
            std::fs::write(&path, &flipped).unwrap();
            let refused = read_checkpoint(&path).unwrap_err();
            assert!(
                refused.contains("digest does not match"),
                "byte {at}: {refused}"
            );
        }
        std::fs::write(&path, &bytes[..5]).unwrap();
        assert!(read_checkpoint(&path).is_err());
        std::fs::write(&path, b"").unwrap();
        assert!(read_checkpoint(&path).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn checkpoint_names_sort_by_step_and_match_no_output_glob() {
        let name = checkpoint_name(42);
        assert_eq!(step_of_name(&name), Some(42));
        assert!(!name.ends_with(".csv") && !name.ends_with(".vtu"));
        assert!(checkpoint_name(9) < checkpoint_name(10));
    }
}
