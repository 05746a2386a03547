//! # fractum-python
//!
//! The extension module `fractum._native` of the Python package `fractum` (tools/python/): the
//! Rust side of scenes, runs, stepping and the analysis tools. The Python half
//! (python/fractum/) gives it its user-facing shape: `Scene`, `run`, `open`, `resume`,
//! `Simulation`, `Run`, and the analysis functions. docs/guide/python.md is the user's guide.
//!
//! Every error a user can cause becomes a Python exception: [`SceneError`] (a `ValueError`)
//! with the file, line, column and field the command line names; [`RunError`] (a
//! `RuntimeError`) for a run that stopped; `OSError` for files. Nothing here panics on input.

use pyo3::prelude::*;

mod analysis;
mod arrays;
mod errors;
mod runs;
mod scene;
mod simulation;
mod strength;

pub use errors::{RunError, SceneError};

/// The module `fractum._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("RunError", py.get_type::<RunError>())?;
    scene::register(m)?;
    runs::register(m)?;
    analysis::register(m)?;
    arrays::register(m)?;
    m.add_class::<simulation::Simulation>()?;
    Ok(())
}
