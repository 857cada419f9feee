//! Task sets for Python without the repository: the benchmark's set is compiled into the extension and written
//! into a cache directory on first use ([`benchmark_dir`]), and training sets are generated from a seed with the
//! same code and bytes as `vb tasks generate` ([`generate`]).

use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use tasks::TaskSet;

include!(concat!(env!("OUT_DIR"), "/task_set_files.rs"));

/// The compiled-in set's version, from its manifest.
fn embedded_version() -> Result<String, String> {
    let (_, bytes) = TASK_SET_FILES
        .iter()
        .find(|(p, _)| *p == "manifest.json")
        .ok_or("the extension carries no task-set manifest")?;
    let m: serde_json::Value = serde_json::from_slice(bytes).map_err(|e| e.to_string())?;
    m["version"]
        .as_str()
        .map(str::to_string)
        .ok_or_else(|| "the compiled-in task-set manifest has no version".to_string())
}

/// True when `dir` holds a complete, unchanged task set of version `version` (every file hashed on load).
fn holds(dir: &Path, version: &str) -> bool {
    TaskSet::load(dir).is_ok_and(|s| s.version() == version)
}

/// Writes the compiled-in files into `dir`.
fn write_files(dir: &Path) -> std::io::Result<()> {
    for (rel, bytes) in TASK_SET_FILES {
        let path = dir.join(rel);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)?;
        }
        std::fs::write(path, bytes)?;
    }
    Ok(())
}

/// The benchmark's task set under `cache` (`cache/tasks/<version>`), written there from the compiled-in copy
/// unless a complete copy is already there. Safe against concurrent first uses: each writer fills a directory of
/// its own and renames it into place; a copy that fails its content check is replaced.
pub fn benchmark_dir(cache: &Path) -> Result<PathBuf, String> {
    let version = embedded_version()?;
    let root = cache.join("tasks");
    let dir = root.join(&version);
    if holds(&dir, &version) {
        return Ok(dir);
    }
    let io = |p: &Path, e: std::io::Error| {
        format!(
            "cannot write the benchmark's task set into {} ({e}); set VERTIBENCH_CACHE to a writable directory",
            p.display()
        )
    };
    std::fs::create_dir_all(&root).map_err(|e| io(&root, e))?;
    let tmp = root.join(format!(".{version}.{}.tmp", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    write_files(&tmp).map_err(|e| io(&tmp, e))?;
    if dir.exists() {
        // An incomplete or changed copy (a crash mid-write, or an edit; it failed the check above): replace it.
        std::fs::remove_dir_all(&dir).map_err(|e| io(&dir, e))?;
    }
    match std::fs::rename(&tmp, &dir) {
        Ok(()) => {}
        // Another process put its copy in place first.
        Err(_) if holds(&dir, &version) => {
            let _ = std::fs::remove_dir_all(&tmp);
        }
        Err(e) => return Err(io(&dir, e)),
    }
    if holds(&dir, &version) {
        Ok(dir)
    } else {
        Err(format!(
            "{}: the task set written there does not load as version {version}",
            dir.display()
        ))
    }
}

/// The benchmark's task set, written into `cache` on first use; returns its directory.
#[pyfunction]
#[pyo3(name = "benchmark_task_dir")]
pub fn py_benchmark_dir(py: Python<'_>, cache: PathBuf) -> PyResult<String> {
    py.detach(|| benchmark_dir(&cache))
        .map(|d| d.display().to_string())
        .map_err(PyOSError::new_err)
}

/// The compiled-in benchmark task set's version.
#[pyfunction]
pub fn benchmark_task_version() -> PyResult<String> {
    embedded_version().map_err(PyValueError::new_err)
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
