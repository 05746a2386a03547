//! `fractum.run` and `fractum.resume`: a scene run to its end into an output folder, with the
//! same files, checkpoints and refusals as `fractum run` and `fractum resume`, the GIL released
//! while it steps.
//!
//! About ten times a second the run takes the GIL back for a moment: to call the progress
//! callback, and to let Python see a signal. A Ctrl-C (SIGINT) then lets the current step
//! finish, the outputs and a checkpoint are written, and `KeyboardInterrupt` is raised, saying
//! how to resume.

use crate::errors::{refusal, run_error, scene_error};
use crate::scene::{parse, registry};
use fractum_cli::resuming::prepare_resume;
use fractum_cli::running::{RunSettings, prepare_out_dir, ready_to_run};
use fractum_io::checkpoint::{CheckpointEvery, SceneRecord};
use fractum_io::run::{CheckpointPlan, ResumedOutputs, RunOptions, RunSummary, run_with};
use fractum_scene::{Built, build_simulation};
use pyo3::exceptions::{PyKeyboardInterrupt, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// How often the run calls back into Python.
const CALL_BACK_EVERY: Duration = Duration::from_millis(100);

/// What `run` and `resume` are told from Python.
struct Request {
    settings: RunSettings,
    progress: Option<Py<PyAny>>,
}

impl Request {
    fn new(
        threads: Option<usize>,
        steps: Option<u64>,
        checkpoint_every: Option<&str>,
        keep_checkpoints: usize,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Self> {
        let checkpoint_every = checkpoint_every
            .map(|every| {
                every.parse::<CheckpointEvery>().map_err(|e| {
                    PyValueError::new_err(format!("checkpoint_every = {every:?}: {e}"))
                })
            })
            .transpose()?;
        let settings = RunSettings {
            threads,
            steps,
            quiet: true,
            checkpoint_every,
            keep_checkpoints: keep_checkpoints.max(1),
        };
        Ok(Self { settings, progress })
    }
}

/// Runs the scene `text` (named `name`: geometry files resolve beside it) into `out`; `record`
/// is the scene path its checkpoints keep. Returns the run's summary as a dict.
#[pyfunction]
#[pyo3(signature = (name, text, record, out, force=false, threads=None, steps=None,
                    checkpoint_every=None, keep_checkpoints=3, progress=None))]
#[allow(clippy::too_many_arguments)]
fn run<'py>(
    py: Python<'py>,
    name: &str,
    text: &str,
    record: &str,
    out: PathBuf,
    force: bool,
    threads: Option<usize>,
    steps: Option<u64>,
    checkpoint_every: Option<&str>,
    keep_checkpoints: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let request = Request::new(threads, steps, checkpoint_every, keep_checkpoints, progress)?;
    let file = parse(name, text)?;
    let mut built = py
        .detach(|| build_simulation(&file, registry()))
        .map_err(|e| scene_error(&e))?;
    ready_to_run(&mut built.simulation, &request.settings, false).map_err(refusal)?;
    prepare_out_dir(&out, force).map_err(|e| refusal((fractum_cli::EXIT_IO, e)))?;
    let scene = SceneRecord {
        path: record.to_string(),
        text: text.to_string(),
    };
    step_to_end(py, built, &out, scene, None, &request)
}

/// Continues the run in `out` from its newest checkpoint; returns its summary as a dict.
#[pyfunction]
#[pyo3(signature = (out, threads=None, steps=None, checkpoint_every=None, keep_checkpoints=3,
                    progress=None))]
fn resume<'py>(
    py: Python<'py>,
    out: PathBuf,
    threads: Option<usize>,
    steps: Option<u64>,
    checkpoint_every: Option<&str>,
    keep_checkpoints: usize,
    progress: Option<Py<PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let request = Request::new(threads, steps, checkpoint_every, keep_checkpoints, progress)?;
    let resumed = py
        .detach(|| prepare_resume(&out, &request.settings, registry()))
        .map_err(refusal)?;
    let outputs = Some(resumed.outputs);
    step_to_end(py, resumed.built, &out, resumed.scene, outputs, &request)
}

/// Steps `built` to its end (or its step cap) into `out_dir`, the GIL released.
fn step_to_end<'py>(
    py: Python<'py>,
    mut built: Built,
    out_dir: &Path,
    scene: SceneRecord,
    resume: Option<ResumedOutputs>,
    request: &Request,
) -> PyResult<Bound<'py, PyDict>> {
    let interrupt = AtomicBool::new(false);
    let mut signal: Option<PyErr> = None;
    let mut callback_error: Option<PyErr> = None;
    let settings = &request.settings;
    let checkpoints = settings.checkpoint_every.map(|every| CheckpointPlan {
        every,
        keep: settings.keep_checkpoints,
    });
    let sim = &mut built.simulation;
    let plan = &built.output;
    let mut last_call = Instant::now();
    let result = py.detach(|| {
        let options = RunOptions {
            checkpoints,
            scene: Some(scene),
            interrupt: Some(&interrupt),
            resume,
            communicator: None,
        };
        run_with(sim, plan, out_dir, options, |sim| {
            if last_call.elapsed() < CALL_BACK_EVERY && !sim.finished() {
                return;
            }
            last_call = Instant::now();
            Python::attach(|py| {
                if signal.is_none()
                    && let Err(e) = py.check_signals()
                {
                    // The run finishes this step and writes its outputs and a checkpoint.
                    interrupt.store(true, Ordering::SeqCst);
                    signal = Some(e);
                }
                if callback_error.is_none()
                    && let Some(callback) = &request.progress
                {
                    let clock = sim.clock();
                    let called = callback.call1(py, (clock.step, clock.time, sim.progress()));
                    if let Err(e) = called {
                        interrupt.store(true, Ordering::SeqCst);
                        // A Ctrl-C while the callback ran surfaces as its `KeyboardInterrupt`:
                        // the same signal as one seen between calls, so the same message.
                        if signal.is_none() && e.is_instance_of::<PyKeyboardInterrupt>(py) {
                            signal = Some(e);
                        } else {
                            callback_error = Some(e);
                        }
                    }
                }
            });
        })
    });
    let names = built.pipeline.system_names();
    let summary = result.map_err(|e| run_error(e, &names))?;
    if let Some(e) = callback_error {
        return Err(e);
    }
    if let Some(e) = signal {
        return Err(interrupted(py, e, &summary, out_dir));
    }
    summary_dict(py, &summary, &built.simulation)
}

/// The `KeyboardInterrupt` of a run stopped by a signal, saying where its outputs are and how
/// to continue it (the signal's own exception where it was not Ctrl-C's).
fn interrupted(py: Python<'_>, signal: PyErr, summary: &RunSummary, out_dir: &Path) -> PyErr {
    if !signal.is_instance_of::<PyKeyboardInterrupt>(py) {
        return signal;
    }
    let dir = out_dir.display();
    let message = match &summary.checkpoint {
        Some(path) => format!(
            "interrupted at step {}; the outputs and a checkpoint ({}) are in {dir}; \
             fractum.resume({:?}) continues the run",
            summary.steps,
            path.display(),
            out_dir.display().to_string(),
        ),
        None => format!(
            "interrupted at step {}; the outputs up to it are in {dir}",
            summary.steps
        ),
    };
    PyKeyboardInterrupt::new_err(message)
}

/// A run's summary as the dict `Run.summary` is.
fn summary_dict<'py>(
    py: Python<'py>,
    summary: &RunSummary,
    sim: &fractum_engine::Simulation,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    out.set_item("steps", summary.steps)?;
    out.set_item("time", summary.time)?;
    out.set_item("particles", summary.particles)?;
    out.set_item("threads", summary.threads)?;
    out.set_item("wall_s", summary.wall.as_secs_f64())?;
    out.set_item("particle_steps_per_s", summary.particle_steps_per_second())?;
    out.set_item("frames", summary.frames)?;
    out.set_item("removed", summary.removed)?;
    out.set_item(
        "checkpoint",
        summary.checkpoint.as_ref().map(|p| p.display().to_string()),
    )?;
    let exit = if summary.interrupted {
        "interrupted"
    } else if sim.at_end() {
        "end"
    } else {
        "steps"
    };
    out.set_item("exit", exit)?;
    Ok(out)
}

/// Adds this file's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(resume, m)?)?;
    Ok(())
}
