//! `fractum.Simulation`: a scene built in memory and stepped from Python, its particles and
//! nodes read as numpy arrays, and the columns a study varies (initial velocities, initial
//! damage, strength scales) set from numpy before the first step. The steps are the engine's own (systems stay
//! Rust), taken with the GIL released.

use crate::arrays::{grid_dict, particle_dict};
use crate::errors::{run_error, scene_error};
use crate::scene::{parse, registry};
use crate::strength::set_strength_scale;
use fractum_engine::components::{Damage, Particle, Velocity};
use fractum_engine::dim::{Dim, VectorOps};
use fractum_engine::prelude::{With, World};
use fractum_engine::storage::single_table;
use fractum_engine::with_dim;
use fractum_io::output::{grid_frame, particle_frame, series_row};
use fractum_scene::{Built, build_simulation};
use numpy::{PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::{PyKeyError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// A scene's simulation, built and held in memory: `step(n)` advances it; `particles()` and
/// `nodes()` return numpy snapshots of its state. Nothing is written to disk.
#[pyclass(module = "fractum._native")]
pub struct Simulation {
    built: Built,
    /// The particles' strengths before any strength scale (the law's, or its Weibull draw),
    /// taken when a scale is first set.
    unscaled_strengths: Option<Vec<f64>>,
}

#[pymethods]
impl Simulation {
    /// Builds the scene `text` (named `name` in messages) with `threads` threads (default: all
    /// cores).
    #[new]
    #[pyo3(signature = (name, text, threads=None))]
    fn new(py: Python<'_>, name: &str, text: &str, threads: Option<usize>) -> PyResult<Self> {
        let file = parse(name, text)?;
        let mut built = py
            .detach(|| build_simulation(&file, registry()))
            .map_err(|e| scene_error(&e))?;
        if let Some(n) = threads {
            built
                .simulation
                .set_threads(n.max(1))
                .map_err(|e| PyRuntimeError::new_err(format!("cannot start {n} threads: {e}")))?;
        }
        Ok(Self {
            built,
            unscaled_strengths: None,
        })
    }

    /// Takes up to `steps` steps, stopping early at the scene's end; returns how many it took.
    /// A blow-up raises `RunError` naming the step, stage and particle.
    #[pyo3(signature = (steps=1))]
    fn step(&mut self, py: Python<'_>, steps: u64) -> PyResult<u64> {
        let sim = &mut self.built.simulation;
        let result = py.detach(|| {
            let mut taken = 0;
            while taken < steps && !sim.finished() {
                sim.step()?;
                taken += 1;
            }
            Ok(taken)
        });
        result.map_err(|blowup| {
            let names = self.built.pipeline.system_names();
            run_error(fractum_io::run::RunError::Blowup(blowup, None), &names)
        })
    }

    /// Simulated time (s).
    #[getter]
    fn time(&self) -> f64 {
        self.built.simulation.clock().time
    }

    /// Steps taken.
    #[getter]
    fn steps(&self) -> u64 {
        self.built.simulation.clock().step
    }

    /// Whether the scene's end is reached.
    #[getter]
    fn finished(&self) -> bool {
        self.built.simulation.finished()
    }

    /// 2 or 3.
    #[getter]
    fn dimension(&self) -> usize {
        self.built.simulation.dimension().count()
    }

    /// The step the next `step` takes (s).
    fn time_step(&mut self) -> f64 {
        self.built.simulation.planned_time_step()
    }

    /// Every particle column, as a dict of arrays (a snapshot: later steps do not change it).
    fn particles<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dimension = self.dimension();
        let frame = particle_frame(&mut self.built.simulation.world);
        particle_dict(py, &frame, dimension)
    }

    /// The grid nodes that carry mass, with their velocity fields, as a dict of arrays.
    fn nodes<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let dimension = self.dimension();
        let frame = grid_frame(&mut self.built.simulation.world);
        grid_dict(py, &frame, dimension)
    }

    /// The row `series.csv` would hold now, as a dict of its columns.
    fn series<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let row = series_row(&mut self.built.simulation.world, &self.built.output);
        let out = PyDict::new(py);
        // A row holds every column but the first, the step, which the clock gives.
        let columns = self.built.output.columns();
        out.set_item(&columns[0], self.built.simulation.clock().step)?;
        for (column, value) in columns.iter().skip(1).zip(row) {
            out.set_item(column, value)?;
        }
        Ok(out)
    }

    /// Sets the scalar column `name` (`damage`, `strength_scale`) of every particle, in the
    /// order `particles()` gives them; only before the first step.
    fn set_scalar(&mut self, name: &str, values: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        self.must_not_have_started(name)?;
        let values = values.as_slice()?;
        let world = &mut self.built.simulation.world;
        match name {
            "damage" => set_damage(world, values)?,
            "strength_scale" => {
                let unscaled = self.unscaled_strengths.get_or_insert_with(Vec::new);
                set_strength_scale(world, values, unscaled)?;
            }
            other => return Err(not_settable(other)),
        }
        reset_energy_account(world);
        Ok(())
    }

    /// Sets the vector column `name` (`velocity`), an `(n, d)` array, of every particle in
    /// the order `particles()` gives them; only before the first step.
    fn set_vector(&mut self, name: &str, values: PyReadonlyArray2<'_, f64>) -> PyResult<()> {
        self.must_not_have_started(name)?;
        let dimension = self.dimension();
        let shape = values.shape().to_vec();
        if shape.get(1) != Some(&dimension) {
            return Err(PyValueError::new_err(format!(
                "`{name}` takes an (n, {dimension}) array in this {dimension}D scene; got shape \
                 {shape:?}"
            )));
        }
        let values = values.as_slice()?;
        let dim = self.built.simulation.dimension();
        let world = &mut self.built.simulation.world;
        match name {
            "velocity" => with_dim!(dim, D => set_velocity::<D>(world, values))?,
            other => return Err(not_settable(other)),
        }
        reset_energy_account(&mut self.built.simulation.world);
        Ok(())
    }
}

impl Simulation {
    fn must_not_have_started(&self, name: &str) -> PyResult<()> {
        let step = self.built.simulation.clock().step;
        if step > 0 {
            return Err(PyRuntimeError::new_err(format!(
                "`{name}` can be set only before the first step (the simulation is at step \
                 {step}): the systems' own state already follows from it"
            )));
        }
        Ok(())
    }
}

fn not_settable(name: &str) -> PyErr {
    PyKeyError::new_err(format!(
        "`{name}` cannot be set from Python: `velocity`, `damage` and `strength_scale` can"
    ))
}

fn wrong_length(name: &str, got: usize, particles: usize) -> PyErr {
    PyValueError::new_err(format!(
        "`{name}` needs one value per particle ({particles}); got {got}"
    ))
}

fn set_damage(world: &mut World, values: &[f64]) -> PyResult<()> {
    if let Some(bad) = values.iter().find(|d| !(0.0..=1.0).contains(*d)) {
        return Err(PyValueError::new_err(format!(
            "damage must lie in [0, 1]; got {bad}"
        )));
    }
    let mut query = world.query_filtered::<&mut Damage, With<Particle>>();
    let Some(mut column) = single_table(query.contiguous_iter_mut(world), "particles") else {
        return Err(wrong_length("damage", values.len(), 0));
    };
    let column: &mut [Damage] = &mut column;
    if column.len() != values.len() {
        return Err(wrong_length("damage", values.len(), column.len()));
    }
    for (d, value) in column.iter_mut().zip(values) {
        d.0 = *value;
    }
    Ok(())
}

fn set_velocity<D: Dim>(world: &mut World, values: &[f64]) -> PyResult<()> {
    if values.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("velocity must be finite"));
    }
    let mut query = world.query_filtered::<&mut Velocity<D>, With<Particle>>();
    let Some(mut column) = single_table(query.contiguous_iter_mut(world), "particles") else {
        return Err(wrong_length("velocity", values.len() / D::N, 0));
    };
    let column: &mut [Velocity<D>] = &mut column;
    if column.len() * D::N != values.len() {
        return Err(wrong_length("velocity", values.len() / D::N, column.len()));
    }
    for (v, row) in column.iter_mut().zip(values.chunks_exact(D::N)) {
        v.0 = D::Vector::from_fn(|axis| row[axis]);
    }
    Ok(())
}

/// The energy account starts from the state the run starts in: after a column is set, its
/// initial energy and first moment are taken again (as the scene builder takes them).
fn reset_energy_account(world: &mut World) {
    let dimension = *world.resource::<fractum_engine::dim::Dimension>();
    let start = fractum_engine::diagnostics::totals(world);
    let moment = with_dim!(dimension, D => fractum_engine::energy::first_moment::<D>(world));
    world.insert_resource(fractum_engine::energy::EnergyAccount::new(
        start.total_energy(),
        moment,
    ));
}
