//! The background frame writer: a run collects each frame from the world on the stepping
//! thread (a copy of the particle or node state, which is quick) and hands it to a thread of
//! its own, which encodes it and writes it atomically while the next steps compute.
//!
//! - Files are written one at a time in the order they were handed over, so a `.pvd`
//!   collection never names a frame that is not yet complete on disk. In a distributed run
//!   each rank writes its own pieces: the ranks agree on the frames whose every piece is on
//!   disk ([`FrameWriter::frames_written`]) before rank 0 lists them.
//! - At most one frame waits while another is written: the queue holds one, and handing over
//!   another blocks until there is room. Beside the state, a run holds at most three frames
//!   (one being written, one queued, one being handed over).
//! - [`FrameWriter::wait`] returns once every file handed over is on disk, with the first
//!   error met. A run waits before a checkpoint (which lists the frames written), when it stops
//!   on a blow-up, and at its end, so it never ends before its files are safe.
//! - The bytes are those of [`super::write_particle_frame`] and [`super::write_grid_frame`]
//!   called directly: the writer only moves them off the stepping thread.

use super::vtu::{grid_frame_file, particle_frame_file};
use super::{FrameCompression, GridFrame, ParticleFrame, write_pvd, write_pvtu};
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// A file that could not be written, and why.
pub type WriteFailure = (PathBuf, std::io::Error);

/// The `.pvtu` index of a distributed run's frame, which the rank that writes it writes after
/// its own piece, declaring the arrays that piece has: the index's file and the pieces'
/// files, relative to its folder.
pub type PieceIndex = (PathBuf, Vec<String>);

enum Job {
    Particles(PathBuf, ParticleFrame, Option<PieceIndex>),
    Grid(PathBuf, GridFrame, Option<PieceIndex>),
    Collection(PathBuf, Vec<(f64, String)>),
    /// Answered once every job before it is done.
    Sync(SyncSender<()>),
}

impl Job {
    /// The file the job writes (none for a sync).
    fn path(&self) -> PathBuf {
        match self {
            Job::Particles(path, ..) | Job::Grid(path, ..) | Job::Collection(path, _) => {
                path.clone()
            }
            Job::Sync(_) => PathBuf::from("frames"),
        }
    }

    fn write(self, compression: FrameCompression) -> Result<(), WriteFailure> {
        let (path, result) = match self {
            Job::Particles(path, frame, index) => {
                let arrays = particle_frame_file(&path, &frame, compression);
                return with_index(path, arrays, index);
            }
            Job::Grid(path, frame, index) => {
                let arrays = grid_frame_file(&path, &frame, compression);
                return with_index(path, arrays, index);
            }
            Job::Collection(path, frames) => {
                let result = write_pvd(&path, &frames);
                (path, result)
            }
            Job::Sync(answer) => {
                let _ = answer.send(());
                return Ok(());
            }
        };
        result.map_err(|e| (path, e))
    }
}

/// After a piece written to `path` with `arrays`, writes the index of its frame, if any.
fn with_index(
    path: PathBuf,
    arrays: std::io::Result<super::PieceArrays>,
    index: Option<PieceIndex>,
) -> Result<(), WriteFailure> {
    let arrays = arrays.map_err(|e| (path, e))?;
    match index {
        Some((index, pieces)) => write_pvtu(&index, &arrays, &pieces).map_err(|e| (index, e)),
        None => Ok(()),
    }
}

/// Writes frames on a thread of its own (see the module's notes).
pub struct FrameWriter {
    jobs: Option<SyncSender<Job>>,
    worker: Option<JoinHandle<()>>,
    /// The first failure; later jobs are dropped unwritten once there is one.
    failure: Arc<Mutex<Option<WriteFailure>>>,
    /// Particle and grid frames (or pieces) on disk so far.
    written: Arc<[AtomicU64; 2]>,
}

impl FrameWriter {
    /// Starts the writer's thread, which encodes frames with `compression`.
    pub fn start(compression: FrameCompression) -> std::io::Result<Self> {
        let (jobs, queue) = sync_channel::<Job>(1);
        let failure = Arc::new(Mutex::new(None));
        let written = Arc::new([AtomicU64::new(0), AtomicU64::new(0)]);
        let shared = (Arc::clone(&failure), Arc::clone(&written));
        let worker = std::thread::Builder::new()
            .name("fractum-frames".into())
            .spawn(move || work(queue, shared, compression))?;
        Ok(Self {
            jobs: Some(jobs),
            worker: Some(worker),
            failure,
            written,
        })
    }

    /// The particle frames and the grid frames (or a distributed run's pieces of them) this
    /// writer has put on disk so far, each with its index when it wrote one.
    pub fn frames_written(&self) -> (u64, u64) {
        let [particles, grid] = &*self.written;
        (
            particles.load(Ordering::Acquire),
            grid.load(Ordering::Acquire),
        )
    }

    /// Hands over a particle frame for `path`.
    pub fn particles(&self, path: PathBuf, frame: ParticleFrame) -> Result<(), WriteFailure> {
        self.submit(Job::Particles(path, frame, None))
    }

    /// Hands over a grid frame for `path`.
    pub fn grid(&self, path: PathBuf, frame: GridFrame) -> Result<(), WriteFailure> {
        self.submit(Job::Grid(path, frame, None))
    }

    /// Hands over a rank's piece of a particle frame for `path`, and the frame's index when
    /// this rank writes it.
    pub fn particle_piece(
        &self,
        path: PathBuf,
        frame: ParticleFrame,
        index: Option<PieceIndex>,
    ) -> Result<(), WriteFailure> {
        self.submit(Job::Particles(path, frame, index))
    }

    /// Hands over a rank's piece of a grid frame for `path`, and the frame's index when this
    /// rank writes it.
    pub fn grid_piece(
        &self,
        path: PathBuf,
        frame: GridFrame,
        index: Option<PieceIndex>,
    ) -> Result<(), WriteFailure> {
        self.submit(Job::Grid(path, frame, index))
    }

    /// Hands over a `.pvd` collection of `frames` (time, file) for `path`.
    pub fn collection(
        &self,
        path: PathBuf,
        frames: Vec<(f64, String)>,
    ) -> Result<(), WriteFailure> {
        self.submit(Job::Collection(path, frames))
    }

    /// Returns once every file handed over is on disk, or with the first failure.
    pub fn wait(&self) -> Result<(), WriteFailure> {
        let (answer, done) = sync_channel(1);
        self.submit(Job::Sync(answer))?;
        // The worker answers when it reaches the job; no answer means its thread has ended.
        if done.recv().is_err() {
            return Err(stopped(PathBuf::from("frames")));
        }
        self.take_failure()
    }

    fn submit(&self, job: Job) -> Result<(), WriteFailure> {
        self.take_failure()?;
        let path = job.path();
        match &self.jobs {
            Some(jobs) if jobs.send(job).is_ok() => self.take_failure(),
            _ => Err(stopped(path)),
        }
    }

    fn take_failure(&self) -> Result<(), WriteFailure> {
        let mut failure = self.failure.lock().unwrap_or_else(|e| e.into_inner());
        match failure.take() {
            Some(f) => {
                // Keep a copy, so every later call reports the same failure.
                let again = (
                    f.0.clone(),
                    std::io::Error::new(f.1.kind(), f.1.to_string()),
                );
                *failure = Some(again);
                Err(f)
            }
            None => Ok(()),
        }
    }
}

impl Drop for FrameWriter {
    /// Finishes the files already handed over: a run that returns early (an error elsewhere)
    /// leaves complete frames, never half-written ones.
    fn drop(&mut self) {
        self.jobs = None;
        if let Some(worker) = self.worker.take() {
            let _ = worker.join();
        }
    }
}

/// The failure of a writer whose thread has ended (it panicked): the frames handed to it
/// since may be missing.
fn stopped(path: PathBuf) -> WriteFailure {
    let why = std::io::Error::other("the frame writer's thread stopped before writing it");
    (path, why)
}

fn work(
    queue: Receiver<Job>,
    (failure, written): (Arc<Mutex<Option<WriteFailure>>>, Arc<[AtomicU64; 2]>),
    compression: FrameCompression,
) {
    for job in queue {
        let counter = match &job {
            Job::Particles(..) => Some(&written[0]),
            Job::Grid(..) => Some(&written[1]),
            _ => None,
        };
        let failed = failure.lock().unwrap_or_else(|e| e.into_inner()).is_some();
        if failed {
            // Answer waits; write nothing more once a file has failed.
            if let Job::Sync(answer) = job {
                let _ = answer.send(());
            }
            continue;
        }
        match job.write(compression) {
            Ok(()) => {
                if let Some(counter) = counter {
                    counter.fetch_add(1, Ordering::Release);
                }
            }
            Err(f) => *failure.lock().unwrap_or_else(|e| e.into_inner()) = Some(f),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::write_particle_frame;

    fn frame(n: usize) -> ParticleFrame {
        ParticleFrame {
            id: (0..n as u32).collect(),
            body: vec![0; n],
            material: vec![0; n],
            position: (0..n).map(|i| [i as f64, 0.5, 0.0]).collect(),
            velocity: vec![[1.0, 2.0, 0.0]; n],
            mass: vec![2.0; n],
            volume: vec![0.25; n],
            stress: vec![[1.0, 0.5, 0.0, 0.5, 2.0, 0.0, 0.0, 0.0, 0.0]; n],
            damage: (0..n).map(|i| i as f64 / n as f64).collect(),
            strain_energy_density: vec![3.0; n],
            thickness: Some(0.1),
            ..Default::default()
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("fractum-writer-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn frames_written_behind_are_the_bytes_written_directly() {
        let dir = scratch("bytes");
        let writer = FrameWriter::start(FrameCompression::Zlib).unwrap();
        for k in 0..4 {
            let path = dir.join(format!("behind_{k}.vtu"));
            writer.particles(path, frame(10 + k)).unwrap();
        }
        let listed = vec![(0.0, "behind_0.vtu".to_string())];
        writer
            .collection(dir.join("all.pvd"), listed.clone())
            .unwrap();
        writer.wait().unwrap();
        for k in 0..4 {
            let direct = dir.join(format!("direct_{k}.vtu"));
            write_particle_frame(&direct, &frame(10 + k), FrameCompression::Zlib).unwrap();
            let behind = std::fs::read(dir.join(format!("behind_{k}.vtu"))).unwrap();
            assert_eq!(behind, std::fs::read(&direct).unwrap(), "frame {k}");
        }
        write_pvd(&dir.join("direct.pvd"), &listed).unwrap();
        assert_eq!(
            std::fs::read(dir.join("all.pvd")).unwrap(),
            std::fs::read(dir.join("direct.pvd")).unwrap()
        );
        drop(writer);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_failed_write_is_reported_with_its_path_and_stops_the_writer() {
        let dir = scratch("failure");
        let writer = FrameWriter::start(FrameCompression::default()).unwrap();
        let unwritable = dir.join("no_such_folder").join("frame.vtu");
        writer.particles(unwritable.clone(), frame(3)).unwrap_or(());
        let (path, _) = writer.wait().unwrap_err();
        assert_eq!(path, unwritable);
        // Every later call reports it, and nothing more is written.
        let later = dir.join("later.vtu");
        assert!(writer.particles(later.clone(), frame(3)).is_err());
        assert!(writer.wait().is_err());
        assert!(!later.exists());
        drop(writer);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn dropping_the_writer_finishes_what_it_was_given() {
        let dir = scratch("drop");
        let writer = FrameWriter::start(FrameCompression::default()).unwrap();
        for k in 0..3 {
            writer
                .particles(dir.join(format!("f{k}.vtu")), frame(50))
                .unwrap();
        }
        drop(writer);
        for k in 0..3 {
            let frame = super::super::read_particle_frame(&dir.join(format!("f{k}.vtu"))).unwrap();
            assert_eq!(frame.id.len(), 50);
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
