//! The vertibench task set: 100 worlds x 10 start/goal pairs.
//!
//! - [`design`]: the balanced assignment of elevation level, semantics kind and obstacle density to world ids.
//! - [`semantics`]: cluster-seeded semantic patches with per-patch friction or soil.
//! - [`obstacles`]: rocks and trees with the release's spacing rules.
//! - [`path`]: A* global paths on the obstacle grid, obstacles inflated by the vehicle footprint.
//! - [`generate`]: the whole pipeline from a seed and a height source to a [`TaskSet`].
//! - [`check`]: the physical ranges of a world file's numbers, checked on load.
//! - [`format`]: the versioned on-disk format (`FORMAT.md`) and [`TaskSet`] loading and saving.
//! - [`heightmap_io`]: external heightmaps (8/16-bit PNG/BMP, `.npy`).
//! - [`import`]: the original Verti-Bench release's worlds.
//! - [`interim`]: procedural height sources of the earlier sets v1 and v2 (the committed set v3's heights come from
//!   the SWAE generator, crate `swae`, which depends on this crate).
//! - [`stats`]: composition and geometry statistics, and the original worlds' per-level statistics sets match.
//! - [`render`]: PNG pictures of worlds and a contact sheet.

pub mod check;
pub mod cli;
pub mod design;
#[cfg(feature = "embedded")]
pub mod embedded;
pub mod format;
pub mod generate;
pub mod heightmap_io;
pub mod import;
pub mod interim;
pub mod obstacles;
pub mod path;
pub mod render;
pub mod selection;
pub mod semantics;
pub mod stats;

pub use format::TaskSet;

use std::path::PathBuf;

/// Every error of this crate names the file and, where it applies, the field.
#[derive(Debug, thiserror::Error)]
pub enum TasksError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: invalid JSON: {source}")]
    Json {
        path: PathBuf,
        source: serde_json::Error,
    },
    #[error("{path}: invalid YAML: {message}")]
    Yaml { path: PathBuf, message: String },
    #[error("{path}: field `{field}`: {message}")]
    Field {
        path: PathBuf,
        field: String,
        message: String,
    },
    #[error("{path}: image: {message}")]
    Image { path: PathBuf, message: String },
    #[error("world {0} is not in the task set")]
    UnknownWorld(u32),
    #[error("invalid parameter `{field}`: {message}")]
    Param { field: String, message: String },
    #[error("world {world}: {message}")]
    Generation { world: u32, message: String },
}

impl TasksError {
    pub(crate) fn field(
        path: impl Into<PathBuf>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        TasksError::Field {
            path: path.into(),
            field: field.into(),
            message: message.into(),
        }
    }
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        TasksError::Io {
            path: path.into(),
            source,
        }
    }
}
