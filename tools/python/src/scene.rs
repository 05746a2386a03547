//! Scenes from Python: their text read and edited by field path (the text keeps its comments
//! and layout, and errors keep pointing at its lines), checked as `fractum check` checks them,
//! and the registered systems listed.

use crate::errors::scene_error;
use fractum_engine::registry::Registry;
use fractum_engine::text::edit;
use fractum_scene::{SceneFile, build_simulation};
use pyo3::exceptions::PyKeyError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::OnceLock;

/// The stock registry, made once.
pub fn registry() -> &'static Registry {
    static REGISTRY: OnceLock<Registry> = OnceLock::new();
    REGISTRY.get_or_init(fractum_systems::stock_registry)
}

/// Parses `text` as the scene `name`, raising `SceneError` where it is not one.
pub fn parse(name: &str, text: &str) -> PyResult<SceneFile> {
    SceneFile::parse(name, text.to_string()).map_err(|e| scene_error(&e))
}

/// The RON text of the value at `path`, or None where the scene has none there.
#[pyfunction]
fn scene_value(text: &str, path: &str) -> Option<String> {
    edit::value_at(text, path).map(str::to_string)
}

/// The names of the values directly inside the one at `path`.
#[pyfunction]
fn scene_children(text: &str, path: &str) -> Vec<String> {
    edit::children(text, path)
}

/// `text` with the value at `path` set to the RON text `value` (added where absent); raises
/// `KeyError` where the path cannot take it and `SceneError` where the result is no scene.
#[pyfunction]
fn scene_set(name: &str, text: &str, path: &str, value: &str) -> PyResult<String> {
    let edited = edit::set_value(text, path, value).map_err(PyKeyError::new_err)?;
    parse(name, &edited)?;
    Ok(edited)
}

/// Checks that `text` parses as a scene (the file format only: no system is installed).
#[pyfunction]
fn scene_parse(name: &str, text: &str) -> PyResult<()> {
    parse(name, text).map(|_| ())
}

/// Builds the scene as `fractum check` does and returns what it reports, as a dict.
#[pyfunction]
fn check<'py>(py: Python<'py>, name: &str, text: &str) -> PyResult<Bound<'py, PyDict>> {
    let file = parse(name, text)?;
    let registry = registry();
    let implausible = fractum_scene::implausible_magnitudes(&file);
    let mut built = py
        .detach(|| build_simulation(&file, registry))
        .map_err(|e| scene_error_with_notes(&e, &implausible))?;
    let (report, length) = py.detach(|| fractum_cli::check_report(&mut built, &implausible));
    let sim = &mut built.simulation;
    let out = PyDict::new(py);
    out.set_item("report", report)?;
    out.set_item("source", &built.summary.source)?;
    out.set_item("title", &built.summary.title)?;
    out.set_item("dimension", sim.dimension().count())?;
    out.set_item("particles", sim.particle_count())?;
    let bodies = PyDict::new(py);
    for (body, count) in &built.summary.bodies {
        bodies.set_item(body, count)?;
    }
    out.set_item("bodies", bodies)?;
    let boundaries = PyDict::new(py);
    for (boundary, condition) in &built.summary.boundaries {
        boundaries.set_item(boundary, condition)?;
    }
    out.set_item("boundaries", boundaries)?;
    let pipeline = PyDict::new(py);
    for (stage, names) in &built.pipeline.by_stage {
        pipeline.set_item(stage.name(), names.clone())?;
    }
    out.set_item("pipeline", pipeline)?;
    out.set_item("stable_time_step", sim.stable_time_step())?;
    out.set_item("time_step", sim.planned_time_step())?;
    match sim.end() {
        fractum_engine::simulation::End::Time(t) => out.set_item("end_time", t)?,
        fractum_engine::simulation::End::Steps(n) => out.set_item("end_steps", n)?,
    }
    out.set_item("steps", length.steps)?;
    out.set_item("step_seconds", length.step_seconds)?;
    out.set_item("wall_estimate_s", length.wall_seconds())?;
    let warnings: Vec<String> = implausible.iter().map(ToString::to_string).collect();
    out.set_item("warnings", warnings)?;
    out.set_item("series_columns", built.output.columns())?;
    out.set_item("vtu_every", built.output.vtu_every)?;
    Ok(out)
}

/// A scene's error with the scene's implausible magnitudes as notes (a unit slip is often what
/// the error is about), in its message and as `notes`.
fn scene_error_with_notes(
    e: &fractum_scene::SceneError,
    implausible: &[fractum_scene::Implausible],
) -> PyErr {
    let err = scene_error(e);
    if implausible.is_empty() {
        return err;
    }
    let notes: Vec<String> = implausible.iter().map(|s| format!("note: {s}")).collect();
    Python::attach(|py| {
        let value = err.value(py);
        let message = format!("{e}\n{}", notes.join("\n"));
        let _ = value.setattr("args", (message,));
        let _ = value.setattr("notes", notes);
    });
    err
}

/// Every registered system: name, stage, summary, parameters and needs.
#[pyfunction]
fn systems(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for registration in registry().iter() {
        let entry = PyDict::new(py);
        entry.set_item("name", registration.name)?;
        entry.set_item("stage", registration.stage().map(|s| s.name()))?;
        entry.set_item("summary", registration.summary)?;
        let params = PyList::empty(py);
        for p in registration.params {
            let param = PyDict::new(py);
            param.set_item("name", p.name)?;
            param.set_item("type", p.ty)?;
            param.set_item("default", p.default)?;
            param.set_item("doc", p.doc)?;
            params.append(param)?;
        }
        entry.set_item("params", params)?;
        entry.set_item("requires", registration.requires.to_vec())?;
        out.append(entry)?;
    }
    Ok(out)
}

/// Adds this file's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(scene_value, m)?)?;
    m.add_function(wrap_pyfunction!(scene_children, m)?)?;
    m.add_function(wrap_pyfunction!(scene_set, m)?)?;
    m.add_function(wrap_pyfunction!(scene_parse, m)?)?;
    m.add_function(wrap_pyfunction!(check, m)?)?;
    m.add_function(wrap_pyfunction!(systems, m)?)?;
    Ok(())
}
