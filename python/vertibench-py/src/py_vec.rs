//! `vertibench._core.VecCore`: a vector of environments stepped in Rust threads with the GIL released; it returns
//! NumPy arrays for the whole batch, so no per-environment Python work happens except for episodes that end.

use crate::obs::{ObsBuf, GOAL_FIELDS, STATE_FIELDS};
use crate::slot::{Autoreset, Settings, Slot, TaskOrder};
use crate::source::Source;
use crate::threads::{default_threads, on_local_pool, ForkSafePool};
use numpy::ndarray::{Array1, Array2, Array3};
use numpy::{IntoPyArray, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use sim_core::episode::EpisodeConfig;
use sim_core::observe::CropSpec;
use sim_core::planner::Action;
use sim_core::reward::RewardWeights;
use std::path::PathBuf;

fn bad(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// A vector of vertibench environments (see `vertibench.vector.VertibenchVectorEnv` for the documented API).
#[pyclass(module = "vertibench._core")]
pub struct VecCore {
    src: Source,
    set: Settings,
    slots: Vec<Slot>,
    pool: ForkSafePool,
}

/// Options of the episode rules, from Python keyword arguments.
fn episode_config(rules: &str, max_time: Option<f64>) -> PyResult<EpisodeConfig> {
    let mut cfg = match rules {
        "paper" => EpisodeConfig::default(),
        "release" => EpisodeConfig::release(),
        other => return Err(bad(format!("rules `{other}` is not `paper` or `release`"))),
    };
    if let Some(t) = max_time {
        if !(t.is_finite() && t > 0.0) {
            return Err(bad(format!("max_time {t} must be positive")));
        }
        cfg.max_time = t;
    }
    Ok(cfg)
}

impl VecCore {
    fn run<R: Send>(
        &mut self,
        py: Python<'_>,
        f: impl Fn(&mut Slot, &Source, &Settings) -> R + Send + Sync,
    ) -> PyResult<Vec<R>> {
        let (src, set, slots) = (&self.src, &self.set, &mut self.slots);
        if self.pool.serial() {
            return Ok(py.detach(|| slots.iter_mut().map(|s| f(s, src, set)).collect()));
        }
        let pool = self.pool.get()?;
        Ok(py.detach(|| pool.install(|| slots.par_iter_mut().map(|s| f(s, src, set)).collect())))
    }

    fn obs_dict<'py>(
        &self,
        py: Python<'py>,
        pick: impl Fn(&Slot) -> &ObsBuf,
        which: &[usize],
    ) -> PyResult<Bound<'py, PyDict>> {
        let n = which.len();
        let d = PyDict::new(py);
        let mut state = Vec::with_capacity(n * STATE_FIELDS.len());
        let mut goal = Vec::with_capacity(n * GOAL_FIELDS.len());
        for &i in which {
            let o = pick(&self.slots[i]);
            state.extend_from_slice(&o.state);
            goal.extend_from_slice(&o.goal);
        }
        let shape_err = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
        d.set_item(
            "state",
            Array2::from_shape_vec((n, STATE_FIELDS.len()), state)
                .map_err(shape_err)?
                .into_pyarray(py),
        )?;
        d.set_item(
            "goal",
            Array2::from_shape_vec((n, GOAL_FIELDS.len()), goal)
                .map_err(shape_err)?
                .into_pyarray(py),
        )?;
        if let Some(c) = &self.set.crop {
            let k = c.size * c.size;
            let mut e = Vec::with_capacity(n * k);
            let mut s = Vec::with_capacity(n * k);
            let mut o = Vec::with_capacity(n * k);
            for &i in which {
                let b = pick(&self.slots[i]);
                e.extend_from_slice(&b.elevation);
                s.extend_from_slice(&b.semantics);
                o.extend_from_slice(&b.obstacles);
            }
            let dims = (n, c.size, c.size);
            d.set_item(
                "elevation",
                Array3::from_shape_vec(dims, e)
                    .map_err(shape_err)?
                    .into_pyarray(py),
            )?;
            d.set_item(
                "semantics",
                Array3::from_shape_vec(dims, s)
                    .map_err(shape_err)?
                    .into_pyarray(py),
            )?;
            d.set_item(
                "obstacles",
                Array3::from_shape_vec(dims, o)
                    .map_err(shape_err)?
                    .into_pyarray(py),
            )?;
            if self.set.perception.degrades_maps() {
                let mut m = Vec::with_capacity(n * k);
                for &i in which {
                    let b = &pick(&self.slots[i]).known;
                    // An environment not reset yet has no mask: nothing is known.
                    m.extend(b.iter().copied().chain(std::iter::repeat(0)).take(k));
                }
                d.set_item(
                    "known",
                    Array3::from_shape_vec(dims, m)
                        .map_err(shape_err)?
                        .into_pyarray(py),
                )?;
            }
        }
        Ok(d)
    }

    fn all(&self) -> Vec<usize> {
        (0..self.slots.len()).collect()
    }
}

#[pymethods]
impl VecCore {
    #[new]
    #[pyo3(signature = (num_envs, task_dir, tasks="all", vehicle="hmmwv", scale=None, control_rate_hz=20.0,
        crop_size=0, crop_resolution=None, rules="paper", max_time=None, reward=None, autoreset="next_step",
        task_order="random", num_threads=None, perception="ideal"))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        num_envs: usize,
        task_dir: PathBuf,
        tasks: &str,
        vehicle: &str,
        scale: Option<f64>,
        control_rate_hz: f64,
        crop_size: usize,
        crop_resolution: Option<f64>,
        rules: &str,
        max_time: Option<f64>,
        reward: Option<[f64; 5]>,
        autoreset: &str,
        task_order: &str,
        num_threads: Option<usize>,
        perception: &str,
    ) -> PyResult<Self> {
        let perception = eval::perception_profile(perception).map_err(|e| bad(e.to_string()))?;
        if num_envs == 0 || num_envs > 4096 {
            return Err(bad(format!("num_envs {num_envs} must be in 1..=4096")));
        }
        if !(control_rate_hz.is_finite() && control_rate_hz > 0.0 && control_rate_hz <= 1000.0) {
            return Err(bad(format!(
                "control_rate_hz {control_rate_hz} must be in (0, 1000]"
            )));
        }
        if crop_size > 512 {
            return Err(bad(format!("crop_size {crop_size} must be at most 512")));
        }
        let episode = episode_config(rules, max_time)?;
        let tasks = tasks.to_string();
        let vehicle = vehicle.to_string();
        let src = py
            .detach(|| {
                on_local_pool(default_threads(usize::MAX), || {
                    Source::load(&task_dir, &tasks, &vehicle, scale, episode)
                })
            })?
            .map_err(bad)?;
        let crop = match crop_size {
            0 => None,
            size => {
                let resolution = crop_resolution.unwrap_or(src.scale);
                if !(resolution.is_finite() && resolution > 0.0) {
                    return Err(bad(format!(
                        "crop_resolution {resolution} must be positive"
                    )));
                }
                Some(CropSpec { size, resolution })
            }
        };
        let weights = reward_weights(reward)?;
        let autoreset = autoreset_named(autoreset)?;
        let order = task_order_named(task_order)?;
        let pool = match num_threads {
            Some(0) => {
                return Err(bad(
                    "num_threads=0: give at least 1, or None for every core",
                ))
            }
            Some(t) => ForkSafePool::new(t.min(num_envs)),
            None => ForkSafePool::new(default_threads(num_envs)),
        };
        let slots = (0..num_envs)
            .map(|i| Slot::new(i, num_envs, crop.as_ref()))
            .collect();
        Ok(VecCore {
            src,
            set: Settings {
                crop,
                control_rate_hz,
                weights,
                autoreset,
                order,
                perception,
            },
            slots,
            pool,
        })
    }

    #[getter]
    fn num_envs(&self) -> usize {
        self.slots.len()
    }

    /// The selected task ids, in the order `task` indices refer to.
    #[getter]
    fn task_ids(&self) -> Vec<String> {
        self.src
            .tasks
            .iter()
            .map(|&(w, t)| contracts::TaskId::new(w, t).to_string())
            .collect()
    }

    /// `(level, semantics, density)` of each selected task.
    #[getter]
    fn task_factors(&self) -> Vec<(&'static str, &'static str, &'static str)> {
        (0..self.src.tasks.len())
            .map(|k| {
                let (lw, _) = self.src.get(k);
                (lw.level, lw.semantics, lw.density)
            })
            .collect()
    }

    /// Selected task `k` with its world's factors (id, world_id, index, start, goal, path, level, semantics,
    /// density, scale).
    fn task<'py>(&self, py: Python<'py>, k: usize) -> PyResult<Bound<'py, PyDict>> {
        if k >= self.src.tasks.len() {
            return Err(bad(format!("task index {k} is out of range")));
        }
        let (lw, t) = self.src.get(k);
        crate::convert::task(py, t, &lw.world)
    }

    /// The ground-truth maps of selected task `k`'s world.
    fn maps<'py>(&self, py: Python<'py>, k: usize) -> PyResult<Bound<'py, PyDict>> {
        if k >= self.src.tasks.len() {
            return Err(bad(format!("task index {k} is out of range")));
        }
        crate::convert::maps(py, &self.src.get(k).0.world)
    }

    /// A top view of selected task `k`'s world, north up, `ppm` pixels per heightmap sample: hill shade tinted by
    /// semantic class, obstacles, the task's global path (red), start (green) and goal (blue); `(H, W, 3)` uint8.
    fn picture<'py>(
        &self,
        py: Python<'py>,
        k: usize,
        ppm: u32,
    ) -> PyResult<Bound<'py, numpy::PyArray3<u8>>> {
        if k >= self.src.tasks.len() {
            return Err(bad(format!("task index {k} is out of range")));
        }
        if !(1..=16).contains(&ppm) {
            return Err(bad(format!("ppm={ppm} must be in 1..=16")));
        }
        let (lw, t) = self.src.get(k);
        let record = tasks::format::WorldRecord {
            world: lw.world.clone(),
            tasks: vec![t.clone()],
            terrain: None,
        };
        let img = py.detach(|| tasks::render::render_world(&record, ppm));
        let (w, h) = (img.width() as usize, img.height() as usize);
        Array3::from_shape_vec((h, w, 3), img.into_raw())
            .map(|a| a.into_pyarray(py))
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))
    }

    #[getter]
    fn task_set_version(&self) -> String {
        self.src.version.clone()
    }

    /// Whether the perception profile degrades the maps: observations then carry a `known` mask of their crops.
    #[getter]
    fn believed(&self) -> bool {
        self.set.perception.degrades_maps()
    }

    #[getter]
    fn crop_size(&self) -> usize {
        self.set.crop.map_or(0, |c| c.size)
    }

    #[getter]
    fn crop_resolution(&self) -> f64 {
        self.set.crop.map_or(0.0, |c| c.resolution)
    }

    #[getter]
    fn scale(&self) -> f64 {
        self.src.scale
    }

    #[getter]
    fn max_time(&self) -> f64 {
        self.src.episode.max_time
    }

    /// The vehicle's facts (as the planner protocol's VehicleInfo) as a dict.
    #[getter]
    fn vehicle<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        crate::convert::vehicle_info(py, &self.src.vehicle.info())
    }

    /// The physics step, s.
    #[getter]
    fn physics_dt(&self) -> f64 {
        sim_core::vehicle::default_dt(self.src.vehicle.scale)
    }

    /// Simulated seconds per step of an environment.
    #[getter]
    fn control_period(&self) -> f64 {
        let dt = sim_core::vehicle::default_dt(self.src.vehicle.scale);
        sim_core::runner::control_every(self.set.control_rate_hz, dt) as f64 * dt
    }

    /// Starts new episodes in the environments `mask` selects (all when `None`); `seed` restarts every
    /// environment's task draws; `tasks` (one selected-task index or `None` per environment) picks tasks. Returns
    /// the observations of all environments and the task index of each.
    #[pyo3(signature = (seed=None, mask=None, tasks=None))]
    fn reset<'py>(
        &mut self,
        py: Python<'py>,
        seed: Option<u64>,
        mask: Option<PyReadonlyArray1<'py, bool>>,
        tasks: Option<Vec<Option<usize>>>,
    ) -> PyResult<(Bound<'py, PyDict>, Vec<usize>)> {
        let n = self.slots.len();
        let mask: Vec<bool> = match mask {
            Some(m) if m.len()? != n => {
                return Err(bad(format!(
                    "mask has {} entries for {n} environments",
                    m.len()?
                )))
            }
            Some(m) => m.as_slice()?.to_vec(),
            None => vec![true; n],
        };
        let picks = match tasks {
            Some(t) if t.len() != n => {
                return Err(bad(format!(
                    "tasks has {} entries for {n} environments",
                    t.len()
                )))
            }
            Some(t) => t,
            None => vec![None; n],
        };
        let count = self.src.tasks.len();
        if let Some(k) = picks.iter().flatten().find(|&&k| k >= count) {
            return Err(bad(format!(
                "task index {k} is out of range: {count} tasks are selected"
            )));
        }
        if let Some(s) = seed {
            self.slots.iter_mut().for_each(|slot| slot.seed(s));
        }
        self.run(py, |slot, src, set| {
            if mask[slot.index] {
                slot.reset(src, set, picks[slot.index]);
            }
        })?;
        let tasks = self.slots.iter().map(|s| s.task).collect();
        Ok((self.obs_dict(py, |s| &s.obs, &self.all())?, tasks))
    }

    /// Steps every environment with its row of `actions` (`num_envs x 3`: steering, throttle, brake). Returns
    /// `(obs, reward terms (num_envs x 4: progress, roll, pitch, terminal), terminated, truncated, was_reset, task,
    /// ended)` where `ended` lists `(env, info dict)` for the episodes that ended on this step.
    #[allow(clippy::type_complexity)]
    fn step<'py>(
        &mut self,
        py: Python<'py>,
        actions: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(
        Bound<'py, PyDict>,
        Bound<'py, numpy::PyArray2<f64>>,
        Bound<'py, numpy::PyArray1<bool>>,
        Bound<'py, numpy::PyArray1<bool>>,
        Bound<'py, numpy::PyArray1<bool>>,
        Vec<usize>,
        Vec<(usize, Bound<'py, PyDict>)>,
    )> {
        let n = self.slots.len();
        let a = actions.as_array();
        if a.shape() != [n, 3] {
            return Err(bad(format!(
                "actions have shape {:?}; expected ({n}, 3)",
                a.shape()
            )));
        }
        let acts: Vec<Action> = a
            .rows()
            .into_iter()
            .map(|r| Action {
                steering: r[0],
                throttle: r[1],
                brake: r[2],
            })
            .collect();
        let results = self.run(py, |slot, src, set| slot.step(src, set, acts[slot.index]))?;
        if let Some(e) = results.into_iter().find_map(Result::err) {
            return Err(PyRuntimeError::new_err(e));
        }
        let mut terms = Vec::with_capacity(n * 4);
        let (mut term, mut trunc, mut reset) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        let mut ended = Vec::new();
        let same_step = self.set.autoreset == Autoreset::SameStep;
        for s in &self.slots {
            terms.extend_from_slice(&s.out.terms);
            term.push(s.out.terminated);
            trunc.push(s.out.truncated);
            reset.push(s.out.was_reset);
            if let Some(e) = &s.out.ended {
                let info = crate::convert::ended_info(py, e, &self.src)?;
                if same_step {
                    let fo = self.obs_dict(py, |x| &x.final_obs, &[s.index])?;
                    info.set_item("final_obs", fo)?;
                }
                ended.push((s.index, info));
            }
        }
        let terms = Array2::from_shape_vec((n, 4), terms)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let tasks = self.slots.iter().map(|s| s.task).collect();
        Ok((
            self.obs_dict(py, |s| &s.obs, &self.all())?,
            terms.into_pyarray(py),
            Array1::from(term).into_pyarray(py),
            Array1::from(trunc).into_pyarray(py),
            Array1::from(reset).into_pyarray(py),
            tasks,
            ended,
        ))
    }
}

fn reward_weights(reward: Option<[f64; 5]>) -> PyResult<RewardWeights> {
    Ok(match reward {
        None => RewardWeights::default(),
        Some([progress, roll, pitch, success_bonus, failure_penalty]) => {
            if ![progress, roll, pitch, success_bonus, failure_penalty]
                .iter()
                .all(|v| v.is_finite())
            {
                return Err(bad("reward weights must be finite"));
            }
            RewardWeights {
                progress,
                roll,
                pitch,
                success_bonus,
                failure_penalty,
            }
        }
    })
}

fn autoreset_named(autoreset: &str) -> PyResult<Autoreset> {
    match autoreset {
        "next_step" => Ok(Autoreset::NextStep),
        "same_step" => Ok(Autoreset::SameStep),
        "disabled" => Ok(Autoreset::Disabled),
        o => Err(bad(format!(
            "autoreset `{o}` is not next_step, same_step or disabled"
        ))),
    }
}

fn task_order_named(task_order: &str) -> PyResult<TaskOrder> {
    match task_order {
        "random" => Ok(TaskOrder::Random),
        "cycle" => Ok(TaskOrder::Cycle),
        o => Err(bad(format!("task_order `{o}` is not random or cycle"))),
    }
}
