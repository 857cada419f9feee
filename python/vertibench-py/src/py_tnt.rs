//! The traversability estimator (`vertibench-tnt-v1`, `planners/learned/KINO.md`) run in Rust for Python, exactly
//! as the `tnt` planner runs it (the parity tests compare it with the PyTorch model and its grid index with the
//! trainer's).

use learned::kino::tal::MAP_SIZE;
use learned::kino::tnt::{self, CHANNELS, GRID, HEADINGS};
use numpy::ndarray::{Array1, Array5, Axis};
use numpy::{
    IntoPyArray, PyArray1, PyArray5, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::collections::BTreeMap;
use std::path::PathBuf;

fn bad(msg: String) -> PyErr {
    PyValueError::new_err(msg)
}

/// A traversability estimator's weights file.
#[pyclass(module = "vertibench._core")]
pub struct TravNet {
    net: learned::kino::TravNet,
}

#[pymethods]
impl TravNet {
    /// Reads `path`; a file of another layout raises ValueError saying what differs.
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        let bytes = std::fs::read(&path).map_err(|e| bad(format!("{}: {e}", path.display())))?;
        learned::kino::TravNet::from_bytes(&bytes)
            .map(|net| TravNet { net })
            .map_err(|e| bad(format!("{}: {e}", path.display())))
    }

    /// The file's metadata.
    #[getter]
    fn metadata(&self) -> BTreeMap<String, String> {
        self.net.metadata().clone()
    }

    /// The grids `f32 [n, 4, 5, 16, 16]` of `maps` (f32 [n, 32, 32]).
    fn estimate<'py>(
        &mut self,
        py: Python<'py>,
        maps: PyReadonlyArray3<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray5<f32>>> {
        let m = maps.as_array();
        let n = m.shape()[0];
        if m.shape() != [n, MAP_SIZE, MAP_SIZE] {
            return Err(bad(format!(
                "maps has shape {:?}; expected [n, {MAP_SIZE}, {MAP_SIZE}]",
                m.shape()
            )));
        }
        let mut out = Array5::<f32>::zeros((n, HEADINGS, CHANNELS.len(), GRID, GRID));
        let mut buf = vec![0f32; MAP_SIZE * MAP_SIZE];
        for i in 0..n {
            buf.iter_mut()
                .zip(m.index_axis(Axis(0), i).iter())
                .for_each(|(d, x)| *d = *x);
            self.net.estimate(&buf);
            out.index_axis_mut(Axis(0), i)
                .iter_mut()
                .zip(self.net.grid())
                .for_each(|(d, x)| *d = *x);
        }
        Ok(out.into_pyarray(py))
    }
}

/// The flat grid index of each pose (f64 [n, 6]) in the grid of the map taken at `anchor` (f64 [6]) at `scale`, or
/// -1 off the grid: what the `tnt` planner looks its rollouts up with.
#[pyfunction]
pub fn tnt_grid_index<'py>(
    py: Python<'py>,
    anchor: PyReadonlyArray1<'py, f64>,
    poses: PyReadonlyArray2<'py, f64>,
    scale: f64,
) -> PyResult<Bound<'py, PyArray1<i64>>> {
    let a = anchor.as_array();
    let p = poses.as_array();
    if a.len() != 6 || p.ncols() != 6 {
        return Err(bad(format!(
            "anchor has {} entries and poses {} columns; expected 6 and 6",
            a.len(),
            p.ncols()
        )));
    }
    let anchor: [f64; 6] = std::array::from_fn(|j| a[j]);
    let out: Array1<i64> = p
        .rows()
        .into_iter()
        .map(|r| {
            let pose: [f64; 6] = std::array::from_fn(|j| r[j]);
            tnt::grid_index(&anchor, &pose, scale).map_or(-1, |i| i as i64)
        })
        .collect();
    Ok(out.into_pyarray(py))
}
