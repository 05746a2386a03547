//! The command line's analysis tools as functions returning data: the same code as
//! `fractum curve`, `fractum crack`, `fractum fragments` and `fractum snapshot`, so Python and
//! the command line give the same numbers.

use fractum_cli::{crack, fragments, plot, snapshot};
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

fn point3(values: &[f64], what: &str) -> PyResult<[f64; 3]> {
    match values {
        [x, y] => Ok([*x, *y, 0.0]),
        [x, y, z] => Ok([*x, *y, *z]),
        _ => Err(PyValueError::new_err(format!(
            "{what} takes 2 or 3 numbers; got {}",
            values.len()
        ))),
    }
}

/// Peak of `y` against `x` in a series.csv, the RMS deviation of its rise (`x` from `start`)
/// from a straight line, and how far `x` runs past the peak before `y` falls below 5% of it
/// (`fall`, None when it never does), as `fractum curve` reports them.
#[pyfunction]
#[pyo3(signature = (csv, x, y, start=0.0))]
fn curve<'py>(
    py: Python<'py>,
    csv: PathBuf,
    x: &str,
    y: &str,
    start: f64,
) -> PyResult<Bound<'py, PyDict>> {
    let series = plot::Series::read(&csv).map_err(PyOSError::new_err)?;
    let xs = series.column(x).map_err(PyValueError::new_err)?;
    let ys = series.column(y).map_err(PyValueError::new_err)?;
    let summary = plot::curve_summary(&xs, &ys, start).ok_or_else(|| {
        PyValueError::new_err(format!("{}: too few points before the peak", csv.display()))
    })?;
    let out = PyDict::new(py);
    out.set_item("peak", summary.peak)?;
    out.set_item("x_at_peak", summary.x_at_peak)?;
    out.set_item("slope", summary.slope)?;
    out.set_item("rms_deviation", summary.rms_deviation)?;
    out.set_item("fall", summary.fall)?;
    Ok(out)
}

/// A crack from a notch through a run's frames, as `fractum crack` traces it: arrays of the
/// tip's time, position and length, and the initial angle and speeds.
#[pyfunction]
#[pyo3(signature = (out, notch, direction=vec![1.0, 0.0], damage_above=0.5, link=None,
                    angle_length=None))]
fn crack_path<'py>(
    py: Python<'py>,
    out: PathBuf,
    notch: Vec<f64>,
    direction: Vec<f64>,
    damage_above: f64,
    link: Option<f64>,
    angle_length: Option<f64>,
) -> PyResult<Bound<'py, PyDict>> {
    let notch_tip = point3(&notch, "notch")?;
    let notch_direction = point3(&direction, "direction")?;
    let link = match link {
        Some(l) => l,
        None => crack::default_link(&out, None).map_err(PyOSError::new_err)?,
    };
    let options = crack::CrackOptions {
        notch_tip,
        notch_direction,
        damage_above,
        link,
        angle_length: angle_length.unwrap_or(crack::DEFAULT_ANGLE_LINKS * link),
    };
    let history = py
        .detach(|| crack::crack_history(&out, &options))
        .map_err(PyOSError::new_err)?;
    let result = PyDict::new(py);
    let time: Vec<f64> = history.iter().map(|t| t.time).collect();
    let length: Vec<f64> = history.iter().map(|t| t.length).collect();
    let tip: Vec<f64> = history.iter().flat_map(|t| t.tip).collect();
    result.set_item("time", time.into_pyarray(py))?;
    result.set_item("length", length.into_pyarray(py))?;
    result.set_item("tip", tip.into_pyarray(py).reshape([history.len(), 3])?)?;
    result.set_item("link", link)?;
    result.set_item("angle_length", options.angle_length)?;
    result.set_item("initial_angle", crack::initial_angle(&history, &options))?;
    let (mean, largest) = crack::crack_speed(&history).unzip();
    result.set_item("speed", mean)?;
    result.set_item("largest_speed", largest)?;
    Ok(result)
}

/// The fragments of a run's frame nearest `time` (the last without it), as `fractum
/// fragments` finds them: arrays per fragment, largest first.
#[pyfunction]
#[pyo3(signature = (out, time=None, damage_below=0.5, link=None, thickness=None, bodies=vec![]))]
fn fragments_of<'py>(
    py: Python<'py>,
    out: PathBuf,
    time: Option<f64>,
    damage_below: f64,
    link: Option<f64>,
    thickness: Option<f64>,
    bodies: Vec<u16>,
) -> PyResult<Bound<'py, PyDict>> {
    let options = fragments::FragmentOptions {
        damage_below,
        link,
        thickness,
        bodies,
    };
    let run = py
        .detach(|| fragments::run_fragments(&out, time, &options))
        .map_err(PyOSError::new_err)?;
    let list = &run.fragments;
    let n = list.len();
    let result = PyDict::new(py);
    result.set_item("time", run.time)?;
    result.set_item("link", run.link)?;
    let scalar = |f: fn(&fragments::Fragment) -> f64| list.iter().map(f).collect::<Vec<f64>>();
    let particles: Vec<u64> = list.iter().map(|f| f.particles as u64).collect();
    result.set_item("particles", particles.into_pyarray(py))?;
    result.set_item("mass", scalar(|f| f.mass).into_pyarray(py))?;
    result.set_item("volume", scalar(|f| f.volume).into_pyarray(py))?;
    result.set_item("diameter", scalar(|f| f.diameter).into_pyarray(py))?;
    let centroid: Vec<f64> = list.iter().flat_map(|f| f.centroid).collect();
    let velocity: Vec<f64> = list.iter().flat_map(|f| f.velocity).collect();
    result.set_item("centroid", centroid.into_pyarray(py).reshape([n, 3])?)?;
    result.set_item("velocity", velocity.into_pyarray(py).reshape([n, 3])?)?;
    Ok(result)
}

/// A PNG of the particle frame `frame` coloured by `field`, as `fractum snapshot` draws it;
/// returns the PNG's path.
#[pyfunction]
#[pyo3(signature = (frame, output, field="damage".to_string(), view="xy", width=900,
                    range=None))]
fn snapshot_png(
    py: Python<'_>,
    frame: PathBuf,
    output: PathBuf,
    field: String,
    view: &str,
    width: u32,
    range: Option<(f64, f64)>,
) -> PyResult<String> {
    let view = match view {
        "xy" => snapshot::View::Xy,
        "xz" => snapshot::View::Xz,
        "yz" => snapshot::View::Yz,
        other => {
            return Err(PyValueError::new_err(format!(
                "view {other:?}: expected \"xy\", \"xz\" or \"yz\""
            )));
        }
    };
    if !(50..=8000).contains(&width) {
        return Err(PyValueError::new_err(format!(
            "width {width}: expected 50 to 8000 pixels"
        )));
    }
    let options = snapshot::SnapshotOptions {
        field,
        view,
        width,
        range,
        overlay: None,
        when: snapshot::frame_when(&frame),
    };
    py.detach(|| {
        let particles = fractum_io::output::read_particle_frame(&frame)
            .map_err(|e| format!("{}: {e}", frame.display()))?;
        snapshot::snapshot(&particles, &options, &output)
    })
    .map_err(PyOSError::new_err)?;
    Ok(output.display().to_string())
}

/// Adds this file's functions to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(curve, m)?)?;
    m.add_function(wrap_pyfunction!(crack_path, m)?)?;
    m.add_function(wrap_pyfunction!(fragments_of, m)?)?;
    m.add_function(wrap_pyfunction!(snapshot_png, m)?)?;
    Ok(())
}
