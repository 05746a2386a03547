//! The exceptions of the package, carrying what the command line says and where.

use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    fractum,
    SceneError,
    PyValueError,
    "A scene the engine refuses: `file`, `line`, `col` (None where the scene has no text \
     there), `field` (the path of the value, such as `materials.steel.youngs_modulus`) and \
     `message`, as `fractum check` says them."
);

pyo3::create_exception!(
    fractum,
    RunError,
    PyRuntimeError,
    "A run that stopped before its end: a blow-up (`step`, `stage`, and the particle or node \
     in `message`), or an output it could not write."
);

/// The Python exception of a scene's error, with its place as attributes.
pub fn scene_error(e: &fractum_scene::SceneError) -> PyErr {
    Python::attach(|py| {
        let err = SceneError::new_err(e.to_string());
        let value = err.value(py);
        let (line, col) = match e.location {
            Some(at) => (Some(at.line), Some(at.col)),
            None => (None, None),
        };
        let set = || -> PyResult<()> {
            value.setattr("file", &e.file)?;
            value.setattr("line", line)?;
            value.setattr("col", col)?;
            value.setattr("field", &e.field)?;
            value.setattr("message", &e.message)?;
            Ok(())
        };
        match set() {
            Ok(()) => err,
            Err(failed) => failed,
        }
    })
}

/// A refusal of the command line's kind (an exit code and its reason) as a Python exception:
/// a scene's as [`SceneError`], a file's as `OSError`, the rest as `ValueError`.
pub fn refusal((code, message): (i32, String)) -> PyErr {
    match code {
        fractum_cli::EXIT_BAD_SCENE => SceneError::new_err(message),
        fractum_cli::EXIT_IO => PyOSError::new_err(message),
        fractum_cli::EXIT_RESOURCES => PyRuntimeError::new_err(message),
        _ => PyValueError::new_err(message),
    }
}

/// A run's failure as [`RunError`], with the blow-up's step and stage as attributes, and the
/// usual cures where the engine knows the cause.
pub fn run_error(e: fractum_io::run::RunError, pipeline: &[&str]) -> PyErr {
    use fractum_io::run::RunError as Failure;
    match e {
        Failure::Blowup(blowup, last_good) => {
            let mut message = format!("the run stopped at {blowup}");
            if let Some(cure) = fractum_cli::remedy::remedy(blowup.cause, pipeline) {
                message.push_str(&format!("\n{cure}"));
            }
            if let Some(path) = last_good {
                let step = blowup.step;
                message.push_str(&format!(
                    "\nthe state at the start of step {step} is in {}",
                    path.display()
                ));
            }
            Python::attach(|py| {
                let err = RunError::new_err(message);
                let value = err.value(py);
                let _ = value.setattr("step", blowup.step);
                let _ = value.setattr("stage", blowup.stage.name());
                err
            })
        }
        Failure::Io { .. } | Failure::Checkpoint(_) => PyOSError::new_err(e.to_string()),
        other => RunError::new_err(other.to_string()),
    }
}
