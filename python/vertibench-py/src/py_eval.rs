//! In-process evaluation: `vertibench.evaluate` runs a Python planner (or a built-in one) on the benchmark with
//! `vb eval`'s own runner and writes `vb eval`'s files. A Python planner is called back at its control rate, one
//! episode at a time; simulated time is frozen while it thinks, as in every benchmark episode.

use crate::convert::vehicle_info;
use numpy::ndarray::Array2;
use numpy::IntoPyArray;
use pyo3::exceptions::{PyKeyboardInterrupt, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use sim_core::episode::EpisodeConfig;
use sim_core::observe::{self, CropSpec};
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::world::World;
use std::io::Write;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A Python planner seen from the episode runner. `glue` is `vertibench.planner`, whose `_core_reset` and
/// `_core_act` turn the runner's plain values into the SDK's types and back.
struct PyPlanner {
    obj: Py<PyAny>,
    glue: Py<PyAny>,
    rate: f64,
    crop: Option<CropSpec>,
    world: Option<World>,
    interrupted: Arc<AtomicBool>,
}

impl PyPlanner {
    /// A Python exception as the planner's failure; Ctrl-C stops the evaluation instead.
    fn failure(&self, py: Python<'_>, e: PyErr) -> PlannerError {
        if e.is_instance_of::<PyKeyboardInterrupt>(py) {
            self.interrupted.store(true, Ordering::SeqCst);
            return PlannerError::Other("interrupted".into());
        }
        let tb = e
            .traceback(py)
            .and_then(|t| t.format().ok())
            .unwrap_or_default();
        PlannerError::Crashed(format!("{tb}{e}"))
    }

    fn reset_py(&mut self, py: Python<'_>, ctx: &PlannerContext<'_>) -> PyResult<()> {
        let (t, w) = (ctx.task, ctx.world);
        let task = crate::convert::task(py, t, w)?;
        let maps = crate::convert::maps(py, w)?;
        let vehicle = vehicle_info(py, ctx.vehicle)?;
        self.glue.call_method1(
            py,
            "_core_reset",
            (&self.obj, task, vehicle, maps, ctx.sim_dt),
        )?;
        self.world = self.crop.map(|_| w.clone());
        Ok(())
    }

    fn act_py(&mut self, py: Python<'_>, obs: &Observation) -> PyResult<Action> {
        let s = &obs.state;
        let state = [
            s.time,
            s.position[0],
            s.position[1],
            s.position[2],
            s.roll,
            s.pitch,
            s.yaw,
            s.velocity[0],
            s.velocity[1],
            s.velocity[2],
            s.angular_velocity[0],
            s.angular_velocity[1],
            s.angular_velocity[2],
            s.speed,
            s.steering,
        ];
        let crops = match (&self.crop, &self.world) {
            (Some(c), Some(w)) => {
                let n = c.size * c.size;
                let (mut e, mut m, mut o) = (vec![0f32; n], vec![0u8; n], vec![0u8; n]);
                observe::elevation_crop(w, s, c, &mut e);
                observe::semantics_crop(w, s, c, &mut m);
                observe::obstacle_crop(w, s, c, &mut o);
                let sq = |v| Array2::from_shape_vec((c.size, c.size), v);
                let err = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
                Some((
                    sq(e).map_err(err)?.into_pyarray(py),
                    Array2::from_shape_vec((c.size, c.size), m)
                        .map_err(err)?
                        .into_pyarray(py),
                    Array2::from_shape_vec((c.size, c.size), o)
                        .map_err(err)?
                        .into_pyarray(py),
                ))
            }
            _ => None,
        };
        let a: (f64, f64, f64) = self
            .glue
            .call_method1(py, "_core_act", (&self.obj, state.to_vec(), crops))?
            .extract(py)?;
        Ok(Action {
            steering: a.0,
            throttle: a.1,
            brake: a.2,
        })
    }
}

impl Planner for PyPlanner {
    fn name(&self) -> &str {
        "python"
    }
    fn control_rate_hz(&self) -> f64 {
        self.rate
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        Python::attach(|py| self.reset_py(py, ctx).map_err(|e| self.failure(py, e)))
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        Python::attach(|py| self.act_py(py, obs).map_err(|e| self.failure(py, e)))
    }
}

/// The episode table of rows: `episodes.csv`'s columns at full precision, then `detail`.
fn table<'py>(py: Python<'py>, rows: &[eval::EpisodeRow]) -> PyResult<Bound<'py, PyDict>> {
    use eval::report::ColumnValues as V;
    let d = PyDict::new(py);
    for c in eval::report::episode_columns(rows) {
        match c.values {
            V::Text(v) => d.set_item(c.name, v)?,
            V::Int(v) => d.set_item(c.name, v)?,
            V::Float(v, _) => d.set_item(c.name, v)?,
            V::OptFloat(v, _) => d.set_item(c.name, v)?,
            V::OptInt(v) => d.set_item(c.name, v)?,
        }
    }
    // `scale` is text in the CSV only to print it at full precision.
    d.set_item("scale", rows.iter().map(|r| r.scale).collect::<Vec<_>>())?;
    d.set_item(
        "detail",
        rows.iter().map(|r| r.detail.as_str()).collect::<Vec<_>>(),
    )?;
    Ok(d)
}

/// Runs an evaluation and writes `vb eval`'s files to `out`; returns its episode table (`episodes.csv`'s columns
/// at full precision, then `detail`). `planner` is
/// the name of a built-in planner (run in parallel) or a `vertibench.planner.Planner` (run one episode at a time).
#[pyfunction]
#[pyo3(signature = (planner, out, task_dir, tasks="all", vehicle="hmmwv", scale=None, rules="paper",
    progress=true))]
#[allow(clippy::too_many_arguments)]
pub fn evaluate<'py>(
    py: Python<'py>,
    planner: Bound<'py, PyAny>,
    out: PathBuf,
    task_dir: PathBuf,
    tasks: &str,
    vehicle: &str,
    scale: Option<f64>,
    rules: &str,
    progress: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let episode = match rules {
        "paper" => EpisodeConfig::default(),
        "release" => EpisodeConfig::release(),
        o => {
            return Err(PyValueError::new_err(format!(
                "rules `{o}` is not `paper` or `release`"
            )))
        }
    };
    let builtin: Option<String> = planner.extract().ok();
    let name = match &builtin {
        Some(n) => n.clone(),
        None => planner.getattr("name")?.extract::<String>()?,
    };
    let cfg = eval::EvalConfig {
        planner: name,
        task_dir,
        tasks: tasks.to_string(),
        vehicle: vehicle.to_string(),
        scale,
        out: out.clone(),
        episode,
    };
    let report = |done: usize, total: usize, secs: f64| {
        if progress && (done.is_multiple_of(10) || done == total) {
            eprint!("\r{done}/{total} episodes, {secs:.0} s ");
            let _ = std::io::stderr().flush();
        }
    };
    let interrupted = Arc::new(AtomicBool::new(false));
    let rows = match builtin {
        Some(_) => py.detach(|| eval::run(&cfg, &report)),
        None => {
            let glue: Py<PyAny> = py.import("vertibench.planner")?.into_any().unbind();
            let rate: f64 = planner.getattr("control_rate_hz")?.extract()?;
            let size: usize = planner.getattr("crop_size")?.extract()?;
            let resolution: f64 = planner.getattr("crop_resolution")?.extract()?;
            let crop = (size > 0).then_some(CropSpec { size, resolution });
            let obj = planner.clone().unbind();
            let make = || -> Box<dyn Planner> {
                Python::attach(|py| {
                    Box::new(PyPlanner {
                        obj: obj.clone_ref(py),
                        glue: glue.clone_ref(py),
                        rate,
                        crop,
                        world: None,
                        interrupted: interrupted.clone(),
                    })
                })
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
            py.detach(|| pool.install(|| eval::run_with(&cfg, &make, &interrupted, &report)))
        }
    }
    .map_err(|e| PyValueError::new_err(e.to_string()))?;
    if progress {
        eprintln!();
    }
    if interrupted.load(Ordering::SeqCst) {
        return Err(PyKeyboardInterrupt::new_err(format!(
            "evaluation interrupted after {} episodes; run it again with the same out= to resume",
            rows.len()
        )));
    }
    let summary = eval::summary::summarise(&rows);
    py.detach(|| eval::report::write(&out, &rows, &summary))
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    table(py, &rows)
}
