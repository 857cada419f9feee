//! The benchmark's task set carried inside a binary (feature `embedded`): every file of the committed set is
//! compiled in, and [`benchmark_dir`] writes it into a versioned cache directory on first use, checking every file
//! of a copy already there (a set's load hashes them all). So `vb`, `vb-submit validate` and the Python wheel find
//! the set they were built with wherever they run, with no path of the tree they were built from.
//!
//! The cache is `$VERTIBENCH_CACHE`, else `$XDG_CACHE_HOME/vertibench`, else `~/.cache/vertibench` ([`cache_root`]);
//! the set lies in `tasks/<version>` below it.

use crate::TaskSet;
use std::path::{Path, PathBuf};

include!(concat!(env!("OUT_DIR"), "/task_set_files.rs"));

/// Why the carried set could not be put in place.
#[derive(Debug, thiserror::Error)]
pub enum EmbeddedError {
    #[error("this binary was built without the benchmark's task set (the tasks crate's `embedded` feature)")]
    NotCarried,
    #[error("the carried task set has a malformed manifest: {0}")]
    Manifest(String),
    #[error(
        "cannot write the benchmark's task set into {path} ({source}); set VERTIBENCH_CACHE to a writable directory"
    )]
    Write {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{0}: the task set written there does not load as the carried version")]
    Check(PathBuf),
}

/// The carried set's version, from its manifest.
pub fn version() -> Result<String, EmbeddedError> {
    let (_, bytes) = TASK_SET_FILES
        .iter()
        .find(|(p, _)| *p == "manifest.json")
        .ok_or(EmbeddedError::NotCarried)?;
    let m: serde_json::Value =
        serde_json::from_slice(bytes).map_err(|e| EmbeddedError::Manifest(e.to_string()))?;
    m["version"]
        .as_str()
        .map(str::to_string)
        .ok_or_else(|| EmbeddedError::Manifest("no version".into()))
}

/// `$VERTIBENCH_CACHE`, else `$XDG_CACHE_HOME/vertibench`, else `$HOME/.cache/vertibench`, else a folder in the
/// system's temporary directory.
pub fn cache_root() -> PathBuf {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    var("VERTIBENCH_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("vertibench")))
        .or_else(|| var("HOME").map(|d| d.join(".cache").join("vertibench")))
        .unwrap_or_else(|| std::env::temp_dir().join("vertibench-cache"))
}

/// Where [`benchmark_dir`] puts the carried set under [`cache_root`] (no IO).
pub fn default_dir() -> PathBuf {
    let v = version().unwrap_or_else(|_| "none".into());
    cache_root().join("tasks").join(v)
}

/// True when `dir` holds a complete, unchanged task set of version `version` (every file hashed on load).
fn holds(dir: &Path, version: &str) -> bool {
    TaskSet::load(dir).is_ok_and(|s| s.version() == version)
}

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

/// The carried set under `cache` (`cache/tasks/<version>`), written there unless a complete copy is already there.
/// Safe against concurrent first uses: each writer fills a directory of its own and renames it into place; a copy
/// that fails its content check is replaced.
pub fn benchmark_dir(cache: &Path) -> Result<PathBuf, EmbeddedError> {
    let version = version()?;
    let root = cache.join("tasks");
    let dir = root.join(&version);
    if holds(&dir, &version) {
        return Ok(dir);
    }
    let io = |path: &Path, source| EmbeddedError::Write {
        path: path.into(),
        source,
    };
    std::fs::create_dir_all(&root).map_err(|e| io(&root, e))?;
    let tmp = root.join(format!(".{version}.{}.tmp", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    write_files(&tmp).map_err(|e| io(&tmp, e))?;
    if dir.exists() && !holds(&dir, &version) {
        // An incomplete or changed copy (a crash mid-write, or an edit): replace it.
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
        Err(EmbeddedError::Check(dir))
    }
}

/// The carried set under [`cache_root`].
pub fn committed_dir() -> Result<PathBuf, EmbeddedError> {
    benchmark_dir(&cache_root())
}
