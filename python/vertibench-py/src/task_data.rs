//! Task sets for Python without the repository: the benchmark's set is compiled into the extension and written
//! into a cache directory on first use ([`benchmark_dir`]), and training sets are generated from a seed with the
//! same code and bytes as `vb tasks generate` ([`generate`]).

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use std::path::PathBuf;
use tasks::TaskSet;

use tasks::embedded::{benchmark_dir, version as embedded_version};

/// The benchmark's task set, written into `cache` on first use; returns its directory.
#[pyfunction]
#[pyo3(name = "benchmark_task_dir")]
pub fn py_benchmark_dir(py: Python<'_>, cache: PathBuf) -> PyResult<String> {
    py.detach(|| benchmark_dir(&cache))
        .map(|d| d.display().to_string())
        .map_err(|e| PyOSError::new_err(e.to_string()))
}

/// The compiled-in benchmark task set's version.
#[pyfunction]
pub fn benchmark_task_version() -> PyResult<String> {
    embedded_version().map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Generates a 100-world task set from `seed` into `out` with the compiled-in SWAE generator: the same bytes as
/// `vb tasks generate --seed SEED [--surface KIND] --out OUT`. Returns `(version, generator)`.
#[pyfunction]
#[pyo3(signature = (out, seed, surface=None))]
pub fn generate(
    py: Python<'_>,
    out: PathBuf,
    seed: u64,
    surface: Option<&str>,
) -> PyResult<(String, String)> {
    let surface = surface
        .map(|s| {
            s.parse::<sim_core::world::SemanticsKind>().map_err(|_| {
                PyValueError::new_err(format!(
                    "surface={s:?} is not a semantics kind (rigid, mixed or deformable)"
                ))
            })
        })
        .transpose()?;
    let source = swae::SwaeSource::committed().map_err(|e| PyValueError::new_err(e.to_string()))?;
    let m = py
        .detach(|| tasks::cli::generate_set_with_surface(&out, seed, &source, surface))
        .map_err(|e| match e {
            tasks::TasksError::Param { message, .. } => {
                PyValueError::new_err(format!("seed={seed}: {message}"))
            }
            tasks::TasksError::Io { .. } => PyOSError::new_err(e.to_string()),
            e => PyValueError::new_err(e.to_string()),
        })?;
    Ok((m.version, m.generator))
}

/// A task set directory's facts, after loading it (every file hashed): `version`, `seed` (None for imported
/// sets), `generator` and `worlds` (their count).
#[pyfunction]
pub fn task_set_info(
    py: Python<'_>,
    dir: PathBuf,
) -> PyResult<(String, Option<u64>, String, usize)> {
    let set = py
        .detach(|| TaskSet::load(&dir))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    let m = &set.manifest;
    Ok((
        m.version.clone(),
        m.seed,
        m.generator.clone(),
        m.worlds.len(),
    ))
}
