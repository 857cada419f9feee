//! The learned kinodynamic models' inputs and inference for Python (`planners/learned/KINO.md`): training computes
//! its samples with [`KinoData`], the same code the Rust hybrid planners run, and [`KinoNet`] runs a weights file
//! as they do (the parity tests compare it with the PyTorch model).

use crate::crops::WorldCache;
use learned::kino::features::{
    apply_delta, crop_features, ground, pose_delta, previous_delta, vector_features, Pose, Scales,
    CROP_SIZE, FEATURES, TARGETS,
};
use numpy::ndarray::{Array2, Array3};
use numpy::{
    IntoPyArray, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::collections::BTreeMap;
use std::path::PathBuf;

fn bad(msg: String) -> PyErr {
    PyValueError::new_err(msg)
}

/// A kinodynamic weights file of either layout; a bad file raises ValueError saying what differs.
pub(crate) fn load_model(path: &std::path::Path) -> PyResult<learned::kino::Dynamics> {
    learned::kino::load(path).map_err(|e| bad(e.to_string()))
}

/// The error for a file of the other model layout, naming the class that reads it.
pub(crate) fn other_layout(path: &std::path::Path, reader: &str) -> PyErr {
    bad(format!(
        "{}: a model of another layout: read it with {reader}",
        path.display()
    ))
}

fn rows<const N: usize>(
    name: &str,
    a: &numpy::ndarray::ArrayView2<'_, f64>,
    n: usize,
) -> PyResult<Vec<[f64; N]>> {
    if a.shape() != [n, N] {
        return Err(bad(format!(
            "{name} has shape {:?}; expected [{n}, {N}]",
            a.shape()
        )));
    }
    Ok(a.rows()
        .into_iter()
        .map(|r| std::array::from_fn(|j| r[j]))
        .collect())
}

/// Makes the models' inputs on the worlds of one task set (worlds loaded once, on first use).
#[pyclass(module = "vertibench._core")]
pub struct KinoData {
    worlds: WorldCache,
    scales: Scales,
    vehicle: sim_core::planner::VehicleInfo,
    spec: sim_core::vehicle::VehicleSpec,
}

#[pymethods]
impl KinoData {
    /// The worlds of the task set in `task_dir` at `scale`, for the built-in vehicle `vehicle` (whose nominal
    /// speed scales the features).
    #[new]
    fn new(py: Python<'_>, task_dir: PathBuf, vehicle: &str, scale: f64) -> PyResult<Self> {
        let spec = sim_core::vehicle::vehicle_by_name(vehicle).map_err(|e| bad(e.to_string()))?;
        let info = spec.info();
        Ok(KinoData {
            worlds: WorldCache::new(py, task_dir, scale)?,
            scales: Scales {
                scale,
                nominal_speed: info.nominal_speed,
            },
            vehicle: info,
            spec,
        })
    }

    /// The vehicle's facts (as the environments' `vehicle`).
    #[getter]
    fn vehicle<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, pyo3::types::PyDict>> {
        crate::convert::vehicle_info(py, &self.vehicle)
    }

    /// The inputs for `n` steps on world `world_id`: `(vec f32 [n, 16], crop f32 [n, 16, 16])` from the pose one
    /// model step before (`before`, f64 [n, 6]: x y z roll pitch yaw; equal to `now` at an episode's start), the
    /// pose at the step's start (`now`), the applied steering there (f64 [n]) and the action held over the step
    /// (f64 [n, 3]: steering, throttle, brake).
    #[allow(clippy::type_complexity)]
    fn features<'py>(
        &mut self,
        py: Python<'py>,
        world_id: u32,
        before: PyReadonlyArray2<'py, f64>,
        now: PyReadonlyArray2<'py, f64>,
        steering: PyReadonlyArray1<'py, f64>,
        action: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray3<f32>>)> {
        let n = now.as_array().nrows();
        let before: Vec<Pose> = rows("before", &before.as_array(), n)?;
        let now: Vec<Pose> = rows("now", &now.as_array(), n)?;
        let action: Vec<[f64; 3]> = rows("action", &action.as_array(), n)?;
        let steering = steering.as_array();
        if steering.len() != n {
            return Err(bad(format!(
                "steering has {} entries; expected {n}",
                steering.len()
            )));
        }
        let steering: Vec<f64> = steering.to_vec();
        let k = self.scales;
        let world = self.worlds.get(py, world_id)?;
        let cells = CROP_SIZE * CROP_SIZE;
        let (v, c) = py.detach(|| {
            let mut v = Vec::with_capacity(n * FEATURES.len());
            let mut c = vec![0f32; n * cells];
            for i in 0..n {
                let g = ground(world, now[i][0], now[i][1]);
                let prev = previous_delta(&before[i], &now[i]);
                v.extend(vector_features(
                    &prev,
                    &now[i],
                    steering[i],
                    &action[i],
                    &g,
                    &k,
                ));
                crop_features(world, &now[i], k.scale, &mut c[i * cells..(i + 1) * cells]);
            }
            (v, c)
        });
        let err = |e: numpy::ndarray::ShapeError| bad(e.to_string());
        Ok((
            Array2::from_shape_vec((n, FEATURES.len()), v)
                .map_err(err)?
                .into_pyarray(py),
            Array3::from_shape_vec((n, CROP_SIZE, CROP_SIZE), c)
                .map_err(err)?
                .into_pyarray(py),
        ))
    }

    /// The terrain-attentive model's inputs for `n` poses `now` (f64 [n, 6]) on world `world_id` over maps taken at
    /// `anchor` (f64 [n, 6]): `(map f32 [n, 32, 32], offset f32 [n, 5])` (`KINO.md`, `vertibench-tal-v1`).
    #[allow(clippy::type_complexity)]
    fn tal_inputs<'py>(
        &mut self,
        py: Python<'py>,
        world_id: u32,
        anchor: PyReadonlyArray2<'py, f64>,
        now: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(Bound<'py, PyArray3<f32>>, Bound<'py, PyArray2<f32>>)> {
        use learned::kino::tal::{map_features, offset_features, MAP_SIZE, OFFSETS};
        let n = now.as_array().nrows();
        let anchor: Vec<Pose> = rows("anchor", &anchor.as_array(), n)?;
        let now: Vec<Pose> = rows("now", &now.as_array(), n)?;
        let scale = self.scales.scale;
        let world = self.worlds.get(py, world_id)?;
        let cells = MAP_SIZE * MAP_SIZE;
        let (m, o) = py.detach(|| {
            let mut m = vec![0f32; n * cells];
            let mut o = Vec::with_capacity(n * OFFSETS.len());
            for i in 0..n {
                map_features(world, &anchor[i], scale, &mut m[i * cells..(i + 1) * cells]);
                o.extend(offset_features(&anchor[i], &now[i], scale));
            }
            (m, o)
        });
        let err = |e: numpy::ndarray::ShapeError| bad(e.to_string());
        Ok((
            Array3::from_shape_vec((n, MAP_SIZE, MAP_SIZE), m)
                .map_err(err)?
                .into_pyarray(py),
            Array2::from_shape_vec((n, OFFSETS.len()), o)
                .map_err(err)?
                .into_pyarray(py),
        ))
    }

    /// Our simulator as a model (the open-loop accuracy report): from each observed state (f64 [n, 15], the
    /// datasets' `observation.state`) on world `world_id`, the vehicle placed there as
    /// `sim_core::Simulation::place_observed` does (the chassis state observed, wheels rolling without slip, the
    /// suspension settled, the soil undeformed) is driven with that start's recorded actions (f64 [n, frames, 3]:
    /// steering, throttle, brake, each held for one control period of `1 / control_rate_hz` s); returns the poses
    /// after the last action (f64 [n, 6]: x y z roll pitch yaw).
    fn simulate<'py>(
        &mut self,
        py: Python<'py>,
        world_id: u32,
        states: PyReadonlyArray2<'py, f64>,
        actions: PyReadonlyArray3<'py, f64>,
        control_rate_hz: f64,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        use sim_core::planner::Action;
        let n = states.as_array().nrows();
        let states: Vec<[f64; 15]> = rows("states", &states.as_array(), n)?;
        let actions = actions.as_array();
        if actions.shape()[0] != n || actions.shape()[2] != 3 {
            return Err(bad(format!(
                "actions has shape {:?}; expected [{n}, frames, 3]",
                actions.shape()
            )));
        }
        if !(control_rate_hz.is_finite() && control_rate_hz > 0.0) {
            return Err(bad(format!(
                "control rate {control_rate_hz} Hz is not positive"
            )));
        }
        let plan: Vec<Vec<Action>> = actions
            .outer_iter()
            .map(|a| {
                a.rows()
                    .into_iter()
                    .map(|r| Action {
                        steering: r[0],
                        throttle: r[1],
                        brake: r[2],
                    })
                    .collect()
            })
            .collect();
        if let Some(e) = plan.iter().flatten().find_map(|a| a.validate().err()) {
            return Err(bad(format!("a recorded action is invalid: {e}")));
        }
        let world = std::sync::Arc::new(self.worlds.get(py, world_id)?.clone());
        let spec = &self.spec;
        let out = py.detach(|| -> Result<Vec<f64>, String> {
            let mut out = Vec::with_capacity(n * 6);
            let Some(first) = states.first() else {
                return Ok(out);
            };
            let mut sim =
                sim_core::Simulation::new_shared(world, spec, first[0], first[1], first[5]);
            let every = sim_core::episode_run::control_every(control_rate_hz, sim.dt());
            for (s, acts) in states.iter().zip(&plan) {
                let observed = sim_core::observe::state_from_vector(s);
                sim.place_observed(&observed).map_err(|e| e.to_string())?;
                for a in acts {
                    for _ in 0..every {
                        sim.step(a);
                    }
                }
                let v = sim.state();
                out.extend([
                    v.position[0],
                    v.position[1],
                    v.position[2],
                    v.roll,
                    v.pitch,
                    v.yaw,
                ]);
            }
            Ok(out)
        });
        let out = out.map_err(bad)?;
        Array2::from_shape_vec((n, 6), out)
            .map_err(|e| bad(e.to_string()))
            .map(|a| a.into_pyarray(py))
    }

    /// The scaled targets `f32 [n, 7]` of steps from pose `now` to pose `after` (f64 [n, 6]) with the applied
    /// steering at the step's end (f64 [n]).
    fn targets<'py>(
        &self,
        py: Python<'py>,
        now: PyReadonlyArray2<'py, f64>,
        after: PyReadonlyArray2<'py, f64>,
        steering_after: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let n = now.as_array().nrows();
        let now: Vec<Pose> = rows("now", &now.as_array(), n)?;
        let after: Vec<Pose> = rows("after", &after.as_array(), n)?;
        let s = steering_after.as_array();
        if s.len() != n {
            return Err(bad(format!(
                "steering_after has {} entries; expected {n}",
                s.len()
            )));
        }
        let f = self.scales.target_factors();
        let mut out = Array2::<f32>::zeros((n, TARGETS.len()));
        for i in 0..n {
            let d = pose_delta(&now[i], &after[i]);
            for j in 0..6 {
                out[[i, j]] = (d[j] / f[j]) as f32;
            }
            out[[i, 6]] = s[i] as f32;
        }
        Ok(out.into_pyarray(py))
    }

    /// The poses `f64 [n, 6]` reached from `now` (f64 [n, 6]) by scaled predictions `pred` (f32 [n, 7]; the
    /// steering entry is ignored): what a planner's rollout does with a model's output.
    fn apply<'py>(
        &self,
        py: Python<'py>,
        now: PyReadonlyArray2<'py, f64>,
        pred: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = now.as_array().nrows();
        let now: Vec<Pose> = rows("now", &now.as_array(), n)?;
        let p = pred.as_array();
        if p.shape() != [n, TARGETS.len()] {
            return Err(bad(format!(
                "pred has shape {:?}; expected [{n}, {}]",
                p.shape(),
                TARGETS.len()
            )));
        }
        let f = self.scales.target_factors();
        let mut out = Array2::<f64>::zeros((n, 6));
        for i in 0..n {
            let d: [f64; 6] = std::array::from_fn(|j| f64::from(p[[i, j]]) * f[j]);
            let q = apply_delta(&now[i], &d);
            out.row_mut(i).iter_mut().zip(q).for_each(|(o, v)| *o = v);
        }
        Ok(out.into_pyarray(py))
    }

    /// The factors that turn scaled targets into metres and radians.
    #[getter]
    fn target_factors(&self) -> [f64; 7] {
        self.scales.target_factors()
    }
}

/// A kinodynamic weights file, run in Rust exactly as the hybrid planners run it.
#[pyclass(module = "vertibench._core")]
pub struct KinoNet {
    net: learned::kino::KinoNet,
}

#[pymethods]
impl KinoNet {
    /// Reads `path`; a file of another layout raises ValueError saying what differs.
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        match load_model(&path)? {
            learned::kino::Dynamics::Crop(net) => Ok(KinoNet { net }),
            _ => Err(other_layout(&path, "TalNet")),
        }
    }

    /// The file's metadata.
    #[getter]
    fn metadata(&self) -> BTreeMap<String, String> {
        self.net.metadata().clone()
    }

    /// Every member's scaled outputs `f32 [n, members, 7]` for `vec` (f32 [n, 16]) and `crop` (f32 [n, 16, 16]).
    fn predict<'py>(
        &mut self,
        py: Python<'py>,
        vec: PyReadonlyArray2<'py, f32>,
        crop: PyReadonlyArray3<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        let (v, c) = (vec.as_array(), crop.as_array());
        let n = v.nrows();
        if v.shape() != [n, FEATURES.len()] || c.shape() != [n, CROP_SIZE, CROP_SIZE] {
            return Err(bad(format!(
                "vec has shape {:?} and crop {:?}; expected [n, {}] and [n, {CROP_SIZE}, {CROP_SIZE}]",
                v.shape(),
                c.shape(),
                FEATURES.len()
            )));
        }
        let (m, t) = (self.net.members(), TARGETS.len());
        let mut out = Array3::<f32>::zeros((n, m, t));
        let mut cbuf = vec![0f32; CROP_SIZE * CROP_SIZE];
        let mut obuf = vec![0f32; m * t];
        for i in 0..n {
            let f: [f32; FEATURES.len()] = std::array::from_fn(|j| v[[i, j]]);
            cbuf.iter_mut()
                .zip(c.index_axis(numpy::ndarray::Axis(0), i).iter())
                .for_each(|(d, x)| *d = *x);
            self.net.predict(&f, &cbuf, &mut obuf);
            out.index_axis_mut(numpy::ndarray::Axis(0), i)
                .iter_mut()
                .zip(&obuf)
                .for_each(|(d, x)| *d = *x);
        }
        Ok(out.into_pyarray(py))
    }
}
