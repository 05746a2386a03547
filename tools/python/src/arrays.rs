//! Particle and grid frames as dicts of numpy arrays: vectors `(n, d)` in the frame's
//! dimension, stresses `(n, 3, 3)` (a 2D frame's plane-strain `σ_zz` kept), scalars `(n,)`.

use fractum_io::output::{GridFrame, ParticleFrame, read_particle_frame, read_pvd};
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::exceptions::PyOSError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// `rows` of `N` values each as an `(n, width)` array of their first `width` values.
fn matrix<'py, const N: usize, T: numpy::Element + Copy>(
    py: Python<'py>,
    rows: &[[T; N]],
    width: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let flat: Vec<T> = rows
        .iter()
        .flat_map(|r| r[..width].iter().copied())
        .collect();
    Ok(flat
        .into_pyarray(py)
        .reshape([rows.len(), width])?
        .into_any())
}

/// The particle frame `frame` of a `dimension`-D scene as a dict of arrays; a column the
/// scene's output left out is absent.
pub fn particle_dict<'py>(
    py: Python<'py>,
    frame: &ParticleFrame,
    dimension: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let n = frame.position.len();
    let full = |len: usize| len == n && n > 0;
    out.set_item("id", frame.id.clone().into_pyarray(py))?;
    out.set_item("body", frame.body.clone().into_pyarray(py))?;
    out.set_item("material", frame.material.clone().into_pyarray(py))?;
    out.set_item("position", matrix(py, &frame.position, dimension)?)?;
    if full(frame.velocity.len()) {
        out.set_item("velocity", matrix(py, &frame.velocity, dimension)?)?;
    }
    for (name, column) in [
        ("mass", &frame.mass),
        ("volume", &frame.volume),
        ("damage", &frame.damage),
        ("strain_energy_density", &frame.strain_energy_density),
    ] {
        if full(column.len()) {
            out.set_item(name, column.clone().into_pyarray(py))?;
        }
    }
    if full(frame.stress.len()) {
        let flat: Vec<f64> = frame.stress.iter().flatten().copied().collect();
        out.set_item("stress", flat.into_pyarray(py).reshape([n, 3, 3])?)?;
    }
    for (name, column) in &frame.scalars {
        out.set_item(name, column.clone().into_pyarray(py))?;
    }
    for (name, column) in &frame.vectors {
        out.set_item(name, matrix(py, column, dimension)?)?;
    }
    Ok(out)
}

/// The grid frame `frame` as a dict of arrays: per node its index, position, number of
/// velocity fields, and per field slot its key, mass, velocity and contact normal.
pub fn grid_dict<'py>(
    py: Python<'py>,
    frame: &GridFrame,
    dimension: usize,
) -> PyResult<Bound<'py, PyDict>> {
    let out = PyDict::new(py);
    let n = frame.index.len();
    let slots = fractum_engine::components::MAX_FIELDS;
    out.set_item("index", frame.index.clone().into_pyarray(py))?;
    out.set_item("position", matrix(py, &frame.position, dimension)?)?;
    out.set_item("fields", frame.fields.clone().into_pyarray(py))?;
    out.set_item("key", matrix(py, &frame.key, slots)?)?;
    out.set_item("mass", matrix(py, &frame.mass, slots)?)?;
    for (name, column) in [("velocity", &frame.velocity), ("normal", &frame.normal)] {
        let flat: Vec<f64> = column
            .iter()
            .flat_map(|node| node.iter().flat_map(|v| v[..dimension].iter().copied()))
            .collect();
        out.set_item(name, flat.into_pyarray(py).reshape([n, slots, dimension])?)?;
    }
    Ok(out)
}

/// The dimension of a frame read from a file: 2D frames record the scene's thickness.
pub fn frame_dimension(frame: &ParticleFrame) -> usize {
    if frame.thickness.is_some() { 2 } else { 3 }
}

/// A particle frame file (`.vtu`, or a distributed run's `.pvtu`) as a dict of arrays, with
/// the frame's `dimension` and, in 2D, its `thickness`.
#[pyfunction]
fn read_frame(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyDict>> {
    let frame = py
        .detach(|| read_particle_frame(&path))
        .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
    let dimension = frame_dimension(&frame);
    let out = particle_dict(py, &frame, dimension)?;
    out.set_item("dimension", dimension)?;
    out.set_item("thickness", frame.thickness)?;
    Ok(out)
}

/// A `.pvd` collection: `(time, file)` of each frame, the file relative to the collection.
#[pyfunction]
fn read_collection(path: PathBuf) -> PyResult<Vec<(f64, String)>> {
    read_pvd(&path).map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))
}

/// Adds this file's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(read_frame, m)?)?;
    m.add_function(wrap_pyfunction!(read_collection, m)?)?;
    Ok(())
}
