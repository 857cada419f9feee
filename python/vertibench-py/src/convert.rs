//! Rust values as Python dicts (vehicle facts, the end of an episode with its metrics).

use crate::slot::Ended;
use crate::source::Source;
use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use sim_core::episode::EpisodeMetrics;
use sim_core::observe;
use sim_core::planner::VehicleInfo;
use sim_core::world::{Task, World};

/// The vehicle's facts, keyed as the planner protocol's `VehicleInfo`.
pub fn vehicle_info<'py>(py: Python<'py>, v: &VehicleInfo) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("name", &v.name)?;
    d.set_item("scale", v.scale)?;
    d.set_item("wheelbase", v.wheelbase)?;
    d.set_item("track", v.track)?;
    d.set_item("length", v.length)?;
    d.set_item("width", v.width)?;
    d.set_item("max_steer", v.max_steer)?;
    d.set_item("skid_steer", v.skid_steer)?;
    d.set_item("nominal_speed", v.nominal_speed)?;
    d.set_item("max_speed", v.max_speed)?;
    Ok(d)
}

/// A task with its world's factors, as `vertibench.planner.make_task` reads it.
pub fn task<'py>(py: Python<'py>, t: &Task, w: &World) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("id", t.id())?;
    d.set_item("world_id", t.world_id)?;
    d.set_item("index", t.index)?;
    d.set_item("start", t.start.to_vec())?;
    d.set_item("goal", t.goal.to_vec())?;
    d.set_item("path", PyList::new(py, t.path.iter().map(|p| p.to_vec()))?)?;
    d.set_item("level", w.level.as_str())?;
    d.set_item("semantics", w.semantics.as_str())?;
    d.set_item("density", w.density.as_str())?;
    d.set_item("scale", w.scale)?;
    Ok(d)
}

fn grid<'py, T: numpy::Element>(
    py: Python<'py>,
    w: &World,
    data: Vec<T>,
) -> PyResult<Bound<'py, PyAny>> {
    let h = &w.heightmap;
    let a = Array2::from_shape_vec((h.ny, h.nx), data)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py).into_any())
}

/// A world's ground-truth maps on its heightmap grid, as `vertibench.planner.Maps` takes them.
pub fn maps<'py>(py: Python<'py>, w: &World) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("elevation", grid(py, w, w.heightmap.heights.clone())?)?;
    d.set_item("semantics", grid(py, w, observe::semantics_grid(w))?)?;
    d.set_item("obstacles", grid(py, w, observe::occupancy_grid(w))?)?;
    d.set_item("friction", grid(py, w, observe::friction_grid(w))?)?;
    d.set_item("cell", w.heightmap.cell)?;
    Ok(d)
}

/// An episode's metrics, named as the columns of `vb eval`'s `episodes.csv`.
pub fn metrics<'py>(py: Python<'py>, m: &EpisodeMetrics) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("time_s", m.time)?;
    d.set_item("roll_abs_mean_deg", m.roll_abs.mean)?;
    d.set_item("roll_abs_max_deg", m.roll_abs.max)?;
    d.set_item("pitch_abs_mean_deg", m.pitch_abs.mean)?;
    d.set_item("pitch_abs_max_deg", m.pitch_abs.max)?;
    d.set_item("path_length_m", m.path_length)?;
    d.set_item("energy_j", m.energy)?;
    d.set_item("obstacle_contacts", m.obstacle_contacts)?;
    d.set_item("final_goal_distance_m", m.final_goal_distance)?;
    d.set_item("steps", m.steps)?;
    Ok(d)
}

/// What the environment reports about an episode that ended: its task, outcome, reason and metrics.
pub fn ended_info<'py>(py: Python<'py>, e: &Ended, src: &Source) -> PyResult<Bound<'py, PyDict>> {
    let (lw, t) = src.get(e.task);
    let d = PyDict::new(py);
    d.set_item("task_id", t.id())?;
    d.set_item("task", e.task)?;
    d.set_item("level", lw.level)?;
    d.set_item("semantics", lw.semantics)?;
    d.set_item("density", lw.density)?;
    d.set_item("outcome", e.outcome.as_str())?;
    d.set_item("success", e.outcome == sim_core::episode::Outcome::Success)?;
    d.set_item("reason", &e.reason)?;
    d.set_item("detail", &e.detail)?;
    d.set_item("metrics", metrics(py, &e.metrics)?)?;
    Ok(d)
}
