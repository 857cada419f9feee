//! The learned policies' inputs and inference for Python (`planners/learned/POLICY.md`): training computes its
//! features with [`policy_features`], the same code the Rust built-in planners run, and [`PolicyNet`] runs a weights
//! file as `vb eval --planner rl|mcl|acl` does (the parity tests compare it with the PyTorch actor).

use learned::features::{
    crop_features, vector_features, Scales, CROP_CHANNELS, CROP_SIZE, FEATURES,
};
use numpy::ndarray::{Array2, Array4};
use numpy::{
    IntoPyArray, PyArray2, PyArray4, PyReadonlyArray1, PyReadonlyArray2, PyReadonlyArray3,
    PyReadonlyArray4,
};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::collections::BTreeMap;

fn bad(msg: String) -> PyErr {
    PyValueError::new_err(msg)
}

fn check_rows(name: &str, shape: &[usize], n: usize, rest: &[usize]) -> PyResult<()> {
    if shape.len() != rest.len() + 1 || shape[0] != n || shape[1..] != *rest {
        let mut want = vec![n];
        want.extend_from_slice(rest);
        return Err(bad(format!(
            "{name} has shape {shape:?}; expected {want:?}"
        )));
    }
    Ok(())
}

/// The policy's features for `n` observations: `(vec f32 [n, 12], crop f32 [n, 2, 16, 16])` from the vector
/// environment's `state` (f64 [n, 15]), `goal` (f64 [n, 3]), the throttle each environment's policy last sent
/// (f64 [n]), `elevation` (f32 [n, 16, 16]) and `obstacles` (u8 [n, 16, 16]), for a vehicle of `scale` and
/// `nominal_speed` (the environment's `vehicle` facts).
#[pyfunction]
#[allow(clippy::too_many_arguments, clippy::type_complexity)]
pub fn policy_features<'py>(
    py: Python<'py>,
    state: PyReadonlyArray2<'py, f64>,
    goal: PyReadonlyArray2<'py, f64>,
    last_throttle: PyReadonlyArray1<'py, f64>,
    elevation: PyReadonlyArray3<'py, f32>,
    obstacles: PyReadonlyArray3<'py, u8>,
    scale: f64,
    nominal_speed: f64,
) -> PyResult<(Bound<'py, PyArray2<f32>>, Bound<'py, PyArray4<f32>>)> {
    if !(scale.is_finite() && scale > 0.0 && nominal_speed.is_finite() && nominal_speed > 0.0) {
        return Err(bad(format!(
            "scale ({scale}) and nominal_speed ({nominal_speed}) must be finite and positive"
        )));
    }
    let (s, g, t) = (state.as_array(), goal.as_array(), last_throttle.as_array());
    let (e, o) = (elevation.as_array(), obstacles.as_array());
    let n = s.nrows();
    check_rows("state", s.shape(), n, &[15])?;
    check_rows("goal", g.shape(), n, &[3])?;
    check_rows("last_throttle", t.shape(), n, &[])?;
    check_rows("elevation", e.shape(), n, &[CROP_SIZE, CROP_SIZE])?;
    check_rows("obstacles", o.shape(), n, &[CROP_SIZE, CROP_SIZE])?;
    let k = Scales {
        scale,
        nominal_speed,
    };
    let cells = CROP_SIZE * CROP_SIZE;
    let mut vec = Array2::<f32>::zeros((n, FEATURES.len()));
    let mut crop = Array4::<f32>::zeros((n, CROP_CHANNELS, CROP_SIZE, CROP_SIZE));
    let (mut ebuf, mut obuf) = (vec![0f32; cells], vec![0u8; cells]);
    for i in 0..n {
        let st: [f64; 15] = std::array::from_fn(|j| s[[i, j]]);
        let gl: [f64; 3] = std::array::from_fn(|j| g[[i, j]]);
        let f = vector_features(&st, &gl, t[i], &k);
        vec.row_mut(i).iter_mut().zip(f).for_each(|(d, v)| *d = v);
        ebuf.iter_mut()
            .zip(e.index_axis(numpy::ndarray::Axis(0), i))
            .for_each(|(d, v)| *d = *v);
        obuf.iter_mut()
            .zip(o.index_axis(numpy::ndarray::Axis(0), i))
            .for_each(|(d, v)| *d = *v);
        let mut out = crop.index_axis_mut(numpy::ndarray::Axis(0), i);
        let dst = out.as_slice_mut().expect("a fresh array is contiguous");
        crop_features(&ebuf, &obuf, scale, dst);
    }
    Ok((vec.into_pyarray(py), crop.into_pyarray(py)))
}

/// A weights file's actor, run in Rust exactly as the built-in planners run it.
#[pyclass(module = "vertibench._core")]
pub struct PolicyNet {
    net: learned::PolicyNet,
}

#[pymethods]
impl PolicyNet {
    /// Reads `path`; a file of another layout raises ValueError saying what differs.
    #[new]
    fn new(path: std::path::PathBuf) -> PyResult<Self> {
        let net = learned::builtin::load_policy(&path).map_err(|e| bad(e.to_string()))?;
        Ok(PolicyNet { net })
    }

    /// The file's metadata.
    #[getter]
    fn metadata(&self) -> BTreeMap<String, String> {
        self.net.metadata().clone()
    }

    /// Deterministic actions `f32 [n, 2]` (steering, throttle) for features `vec` (f32 [n, 12]) and `crop`
    /// (f32 [n, 2, 16, 16]).
    fn act<'py>(
        &mut self,
        py: Python<'py>,
        vec: PyReadonlyArray2<'py, f32>,
        crop: PyReadonlyArray4<'py, f32>,
    ) -> PyResult<Bound<'py, PyArray2<f32>>> {
        let (v, c) = (vec.as_array(), crop.as_array());
        let n = v.nrows();
        check_rows("vec", v.shape(), n, &[FEATURES.len()])?;
        check_rows("crop", c.shape(), n, &[CROP_CHANNELS, CROP_SIZE, CROP_SIZE])?;
        let mut out = Array2::<f32>::zeros((n, 2));
        let mut cbuf = vec![0f32; CROP_CHANNELS * CROP_SIZE * CROP_SIZE];
        for i in 0..n {
            let f: [f32; FEATURES.len()] = std::array::from_fn(|j| v[[i, j]]);
            cbuf.iter_mut()
                .zip(c.index_axis(numpy::ndarray::Axis(0), i).iter())
                .for_each(|(d, x)| *d = *x);
            let a = self.net.act(&f, &cbuf);
            out[[i, 0]] = a[0];
            out[[i, 1]] = a[1];
        }
        Ok(out.into_pyarray(py))
    }
}
