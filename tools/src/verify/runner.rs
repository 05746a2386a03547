//! Runs the cases' scenes as child `fractum` processes, up to `--jobs` at once, each with
//! `--threads`: a fresh run, the resumption of an interrupted one from its checkpoint, or
//! nothing when the work folder already holds the finished run of the same key.
//!
//! Each case's work folder (`WORK/<case>/`) holds the edited scene (`scene.ron`), the key of the
//! run (`key`), its outputs (`run/`), the child's output (`log.txt`) and, once the run reached
//! its end, `done`. Children run in their own process group, so a Ctrl-C reaches `verify`
//! alone, which passes one SIGINT to each child: every child finishes its step and writes a
//! checkpoint, and the next `verify` resumes it.

use fractum_io::output::write_atomically;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Instant;

/// Steps between the checkpoints of a case's run.
const CHECKPOINT_EVERY: &str = "2000";

/// What a case's work folder asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Plan {
    /// The finished run of this key is there: measure it.
    Measure,
    /// An interrupted run of this key is there: continue it.
    Resume,
    /// Start a new run.
    Fresh,
}

/// A case's work folder.
#[derive(Clone, Debug)]
pub struct WorkDir {
    /// The folder.
    pub dir: PathBuf,
}

impl WorkDir {
    /// The folder for case `name` under `work`.
    pub fn new(work: &Path, name: &str) -> Self {
        Self {
            dir: work.join(name),
        }
    }

    /// The run's output folder.
    pub fn run_dir(&self) -> PathBuf {
        self.dir.join("run")
    }

    /// The edited scene.
    pub fn scene(&self) -> PathBuf {
        self.dir.join("scene.ron")
    }

    /// The child's output.
    pub fn log(&self) -> PathBuf {
        self.dir.join("log.txt")
    }

    fn key_file(&self) -> PathBuf {
        self.dir.join("key")
    }

    fn done_file(&self) -> PathBuf {
        self.dir.join("done")
    }

    /// Whether the finished run of `key` is here.
    pub fn finished(&self, key: &str) -> bool {
        self.holds(key) && self.done_file().exists()
    }

    fn holds(&self, key: &str) -> bool {
        std::fs::read_to_string(self.key_file()).is_ok_and(|k| k.trim() == key)
    }

    /// What to do for a run of `key`.
    pub fn plan(&self, key: &str) -> Plan {
        if self.finished(key) {
            Plan::Measure
        } else if self.holds(key) && self.run_dir().join("checkpoints").is_dir() {
            Plan::Resume
        } else {
            Plan::Fresh
        }
    }

    /// Makes the folder ready for a fresh run of `key` with `scene` as its text: the previous
    /// run's files go, the key is written last so an interruption in between leaves no stale
    /// key.
    pub fn prepare_fresh(&self, key: &str, scene: &str) -> Result<(), String> {
        if self.dir.exists() {
            std::fs::remove_dir_all(&self.dir)
                .map_err(|e| format!("cannot clear {}: {e}", self.dir.display()))?;
        }
        std::fs::create_dir_all(&self.dir)
            .map_err(|e| format!("cannot create {}: {e}", self.dir.display()))?;
        write_atomically(&self.scene(), scene.as_bytes())
            .and_then(|()| write_atomically(&self.key_file(), key.as_bytes()))
            .map_err(|e| format!("cannot write into {}: {e}", self.dir.display()))
    }

    /// Marks the run finished.
    pub fn mark_done(&self) -> Result<(), String> {
        write_atomically(&self.done_file(), b"")
            .map_err(|e| format!("cannot write {}: {e}", self.done_file().display()))
    }

    /// Wall time the run has taken in earlier sittings (s).
    pub fn earlier_wall(&self) -> f64 {
        std::fs::read_to_string(self.dir.join("wall_s"))
            .ok()
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(0.0)
    }

    /// Adds `seconds` to the wall time recorded.
    pub fn add_wall(&self, seconds: f64) {
        let total = self.earlier_wall() + seconds;
        // Only the reported wall time depends on it.
        let _ = write_atomically(&self.dir.join("wall_s"), format!("{total}").as_bytes());
    }

    /// The simulated time of the run's last series row, for progress.
    pub fn simulated_time(&self) -> Option<f64> {
        let text = read_tail(&self.run_dir().join("series.csv"), 4096)?;
        let last = text.lines().rev().find(|l| !l.is_empty())?;
        last.split(',').nth(1)?.parse().ok()
    }

    /// The error lines of the child's output (those after the first `error:`), or its last
    /// lines when it printed none.
    pub fn failure(&self) -> String {
        let text = std::fs::read_to_string(self.log()).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        let start = lines
            .iter()
            .position(|l| l.starts_with("error:"))
            .unwrap_or(lines.len().saturating_sub(3));
        let message = lines[start..].join(" ").trim().to_string();
        if message.is_empty() {
            "the run printed nothing".into()
        } else {
            message
        }
    }
}

fn read_tail(path: &Path, bytes: u64) -> Option<String> {
    use std::io::{Read, Seek, SeekFrom};
    let mut file = std::fs::File::open(path).ok()?;
    let length = file.metadata().ok()?.len();
    file.seek(SeekFrom::Start(length.saturating_sub(bytes)))
        .ok()?;
    let mut buffer = Vec::new();
    file.read_to_end(&mut buffer).ok()?;
    Some(String::from_utf8_lossy(&buffer).into_owned())
}

/// A running child.
pub struct Running {
    /// Index of the case in the selection.
    pub index: usize,
    /// The child.
    pub child: Child,
    /// When it started.
    pub started: Instant,
    /// Whether it resumes (a refused resume starts afresh).
    pub resuming: bool,
}

/// Starts the child for `work`: `fractum run` of its scene, or `fractum resume` of its run.
pub fn spawn(
    exe: &Path,
    work: &WorkDir,
    resume: bool,
    threads: usize,
    steps: Option<u64>,
) -> Result<Child, String> {
    let log = std::fs::File::create(work.log())
        .map_err(|e| format!("cannot write {}: {e}", work.log().display()))?;
    let err = log
        .try_clone()
        .map_err(|e| format!("cannot write {}: {e}", work.log().display()))?;
    let mut command = Command::new(exe);
    if resume {
        command.arg("resume").arg(work.run_dir());
    } else {
        command
            .arg("run")
            .arg(work.scene())
            .arg("--out")
            .arg(work.run_dir())
            .arg("--force");
    }
    command.args(["--quiet", "--keep-checkpoints", "1", "--checkpoint-every"]);
    command.arg(CHECKPOINT_EVERY);
    command.arg("--threads").arg(threads.to_string());
    if let Some(steps) = steps {
        command.arg("--steps").arg(steps.to_string());
    }
    own_process_group(&mut command);
    command
        .stdin(Stdio::null())
        .stdout(Stdio::from(log))
        .stderr(Stdio::from(err))
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", exe.display()))
}

#[cfg(unix)]
fn own_process_group(command: &mut Command) {
    use std::os::unix::process::CommandExt;
    command.process_group(0);
}

#[cfg(not(unix))]
fn own_process_group(_: &mut Command) {}

/// Asks `child` to stop after its step and write a checkpoint (SIGINT); elsewhere than Unix,
/// stops it at once.
pub fn interrupt(child: &mut Child) {
    #[cfg(unix)]
    {
        use nix::sys::signal::{Signal, kill};
        use nix::unistd::Pid;
        if let Ok(pid) = i32::try_from(child.id()) {
            // A child that has just exited cannot be signalled; nothing is lost.
            let _ = kill(Pid::from_raw(pid), Signal::SIGINT);
        }
    }
    #[cfg(not(unix))]
    {
        let _ = child.kill();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_work_folder_plans_by_its_key_and_its_files() {
        let root = std::env::temp_dir().join(format!("fractum-work-{}", std::process::id()));
        let work = WorkDir::new(&root, "case");
        assert_eq!(work.plan("k1"), Plan::Fresh);
        work.prepare_fresh("k1", "(scene)").unwrap();
        assert_eq!(work.plan("k1"), Plan::Fresh);
        std::fs::create_dir_all(work.run_dir().join("checkpoints")).unwrap();
        assert_eq!(work.plan("k1"), Plan::Resume);
        assert_eq!(work.plan("k2"), Plan::Fresh);
        work.mark_done().unwrap();
        assert_eq!(work.plan("k1"), Plan::Measure);
        work.add_wall(2.0);
        work.add_wall(3.5);
        assert_eq!(work.earlier_wall(), 5.5);
        std::fs::write(
            work.run_dir().join("series.csv"),
            "step,time\n0,0\n10,2.5e-3\n",
        )
        .unwrap();
        assert_eq!(work.simulated_time(), Some(2.5e-3));
        std::fs::write(work.log(), "note: x\nerror: scene.ron:3:4: `grid`: bad\n").unwrap();
        assert_eq!(work.failure(), "error: scene.ron:3:4: `grid`: bad");
        work.prepare_fresh("k2", "(other)").unwrap();
        assert!(!work.run_dir().exists() && work.plan("k2") == Plan::Fresh);
        std::fs::remove_dir_all(root).unwrap();
    }
}
