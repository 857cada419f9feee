//! Map crops rebuilt from poses: the lite datasets store no crops, and `vertibench.datasets` rebuilds the ones the
//! environment observed from the task set and each frame's pose, with the environment's own code (`obs.rs`).

use crate::obs::ObsBuf;
use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use sim_core::observe::CropSpec;
use sim_core::planner::VehicleState;
use sim_core::world::World;
use std::collections::BTreeMap;
use std::path::PathBuf;
use tasks::TaskSet;

fn bad(msg: impl Into<String>) -> PyErr {
    PyValueError::new_err(msg.into())
}

/// The worlds of one task set at one scale, each loaded on first use.
pub struct WorldCache {
    set: TaskSet,
    scale: f64,
    worlds: BTreeMap<u32, World>,
}

impl WorldCache {
    pub fn new(py: Python<'_>, task_dir: PathBuf, scale: f64) -> PyResult<Self> {
        if !(scale.is_finite() && scale > 0.0 && scale <= 1.0) {
            return Err(bad(format!("scale {scale} must be in (0, 1]")));
        }
        let set = py
            .detach(|| TaskSet::load(&task_dir))
            .map_err(|e| bad(e.to_string()))?;
        Ok(WorldCache {
            set,
            scale,
            worlds: BTreeMap::new(),
        })
    }

    /// World `world_id`, loaded now if it is not yet.
    pub fn get(&mut self, py: Python<'_>, world_id: u32) -> PyResult<&World> {
        if !self.worlds.contains_key(&world_id) {
            let w = py
                .detach(|| self.set.world(world_id, self.scale))
                .map_err(|e| bad(e.to_string()))?;
            self.worlds.insert(world_id, w);
        }
        Ok(&self.worlds[&world_id])
    }
}

/// Makes the environments' crops for poses on the worlds of one task set (worlds loaded once, on first use).
#[pyclass(module = "vertibench._core")]
pub struct CropMaker {
    worlds: WorldCache,
    spec: CropSpec,
}

#[pymethods]
impl CropMaker {
    #[new]
    fn new(
        py: Python<'_>,
        task_dir: PathBuf,
        scale: f64,
        size: usize,
        resolution: f64,
    ) -> PyResult<Self> {
        if !(1..=512).contains(&size) {
            return Err(bad(format!("crop size {size} must be in 1..=512")));
        }
        if !(resolution.is_finite() && resolution > 0.0) {
            return Err(bad(format!(
                "crop resolution {resolution} must be positive"
            )));
        }
        Ok(CropMaker {
            worlds: WorldCache::new(py, task_dir, scale)?,
            spec: CropSpec { size, resolution },
        })
    }

    /// The task set's version.
    #[getter]
    fn version(&self) -> String {
        self.worlds.set.version().to_string()
    }

    /// Crops for `poses` (`n x 4`: x, y, z, yaw) on world `world_id`: `(elevation, semantics, obstacles)`, each
    /// `n x size x size` (float32 relative to the pose's height, uint8, uint8), exactly as the environments
    /// observe them.
    #[allow(clippy::type_complexity)]
    fn crops<'py>(
        &mut self,
        py: Python<'py>,
        world_id: u32,
        poses: PyReadonlyArray2<'py, f64>,
    ) -> PyResult<(
        Bound<'py, PyArray3<f32>>,
        Bound<'py, PyArray3<u8>>,
        Bound<'py, PyArray3<u8>>,
    )> {
        let p = poses.as_array();
        if p.ncols() != 4 {
            return Err(bad(format!(
                "poses have shape {:?}; expected (n, 4): x, y, z, yaw",
                p.shape()
            )));
        }
        let spec = self.spec;
        let world = self.worlds.get(py, world_id)?;
        let (n, k) = (p.nrows(), spec.size);
        let rows: Vec<[f64; 4]> = p
            .rows()
            .into_iter()
            .map(|r| [r[0], r[1], r[2], r[3]])
            .collect();
        let (e, s, o) = py.detach(|| {
            let mut buf = ObsBuf::new(Some(&spec));
            let (mut e, mut s, mut o) = (
                Vec::with_capacity(n * k * k),
                Vec::with_capacity(n * k * k),
                Vec::with_capacity(n * k * k),
            );
            for [x, y, z, yaw] in rows {
                let state = VehicleState {
                    position: [x, y, z],
                    yaw,
                    ..VehicleState::default()
                };
                buf.write(&state, world, [x, y], Some(&spec), false);
                e.extend_from_slice(&buf.elevation);
                s.extend_from_slice(&buf.semantics);
                o.extend_from_slice(&buf.obstacles);
            }
            (e, s, o)
        });
        let shape = (n, k, k);
        let err = |e: numpy::ndarray::ShapeError| PyValueError::new_err(e.to_string());
        Ok((
            Array3::from_shape_vec(shape, e)
                .map_err(err)?
                .into_pyarray(py),
            Array3::from_shape_vec(shape, s)
                .map_err(err)?
                .into_pyarray(py),
            Array3::from_shape_vec(shape, o)
                .map_err(err)?
                .into_pyarray(py),
        ))
    }
}
