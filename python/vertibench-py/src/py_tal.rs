//! The terrain-attentive model (`vertibench-tal-v1`, `planners/learned/KINO.md`) run in Rust for Python, exactly as
//! the `tal` planner runs it (the parity tests compare it with the PyTorch model).

use numpy::ndarray::Array3;
use numpy::{IntoPyArray, PyArray3, PyReadonlyArray2, PyReadonlyArray3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A terrain-attentive weights file.
#[pyclass(module = "vertibench._core")]
pub struct TalNet {
    net: learned::kino::TalNet,
}

#[pymethods]
impl TalNet {
    /// Reads `path`; a file of another layout raises ValueError saying what differs.
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        match crate::py_kino::load_model(&path)? {
            learned::kino::Dynamics::Attention(net) => Ok(TalNet { net }),
            _ => Err(crate::py_kino::other_layout(&path, "KinoNet")),
        }
    }

    /// The file's metadata.
    #[getter]
    fn metadata(&self) -> BTreeMap<String, String> {
        self.net.metadata().clone()
    }

    /// Every member's scaled outputs `f32 [n, members, 7]` for `vec` (f32 [n, 16]), `map` (f32 [n, 32, 32]; each
    /// sample's own) and `offset` (f32 [n, 5]).
    fn predict<'py>(
        &mut self,
        py: Python<'py>,
        vec: PyReadonlyArray2<'py, f32>,
        map: PyReadonlyArray3<'py, f32>,
        offset: PyReadonlyArray2<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray3<f32>>> {
        use learned::kino::features::{FEATURES, TARGETS};
        use learned::kino::tal::{MAP_SIZE, OFFSETS};
        let (v, m, o) = (vec.as_array(), map.as_array(), offset.as_array());
        let n = v.nrows();
        if v.shape() != [n, FEATURES.len()]
            || m.shape() != [n, MAP_SIZE, MAP_SIZE]
            || o.shape() != [n, OFFSETS.len()]
        {
            return Err(PyValueError::new_err(format!(
                "vec, map and offset have shapes {:?}, {:?} and {:?}; expected [n, {}], [n, {MAP_SIZE}, \
                 {MAP_SIZE}] and [n, {}]",
                v.shape(),
                m.shape(),
                o.shape(),
                FEATURES.len(),
                OFFSETS.len()
            )));
        }
        let (k, t) = (self.net.members(), TARGETS.len());
        let mut out = Array3::<f32>::zeros((n, k, t));
        let mut mbuf = vec![0f32; MAP_SIZE * MAP_SIZE];
        let mut obuf = vec![0f32; k * t];
        for i in 0..n {
            let f: [f32; FEATURES.len()] = std::array::from_fn(|j| v[[i, j]]);
            let off: [f32; OFFSETS.len()] = std::array::from_fn(|j| o[[i, j]]);
            mbuf.iter_mut()
                .zip(m.index_axis(numpy::ndarray::Axis(0), i).iter())
                .for_each(|(d, x)| *d = *x);
            self.net.embed(&mbuf);
            self.net.predict(&f, &off, &mut obuf);
            out.index_axis_mut(numpy::ndarray::Axis(0), i)
                .iter_mut()
                .zip(&obuf)
                .for_each(|(d, x)| *d = *x);
        }
        Ok(out.into_pyarray(py))
    }
}
