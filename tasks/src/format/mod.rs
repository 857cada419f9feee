//! The versioned on-disk format of a task set (documented in `tasks/FORMAT.md`).
//!
//! ```text
//! <dir>/manifest.json      format tag, task-set version (content hash), seed, generator, world list
//! <dir>/worlds/NNN.json    human-readable world spec: factors, height range, patches, obstacles, tasks
//! <dir>/worlds/NNN.png     16-bit grayscale heightmap, 129 x 129, row 0 = north edge (the release's BMP orientation)
//! ```
//! Heights are quantised to 16 bits over `[height_min, height_max]` of the world spec (a step of at most 0.25 mm for
//! 16 m of relief). The version is the first 16 hex digits of the SHA-256 over every world file (name and bytes, in
//! id order), so any change to any world gives a new version.
//!
//! Split by responsibility: the manifest and world-file types and shared helpers here; [`world_file`] converts a
//! world to and from its `NNN.json` and `NNN.png`; [`write`] writes a set and computes its version; [`task_set`]
//! opens a set and loads its worlds.

mod task_set;
mod world_file;
mod write;

pub use world_file::load_record;
pub use write::{content_version, save};

use crate::TasksError;
use serde::{Deserialize, Serialize};
use sim_core::world::{
    ElevationLevel, Obstacle, ObstacleDensity, Semantic, SemanticsKind, Task, World,
};
use std::path::{Path, PathBuf};

/// Format tag of this version of the format.
pub const FORMAT: &str = "vertibench-tasks/1";

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub format: String,
    /// Content hash naming this task set.
    pub version: String,
    /// Master seed the set was generated from (absent for imported sets).
    pub seed: Option<u64>,
    /// How the heights were made, e.g. `swae:<weights sha256 prefix>` or `import:verti-bench`.
    pub generator: String,
    pub worlds: Vec<WorldEntry>,
}

/// One world in the manifest (enough to filter without loading heights).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldEntry {
    pub id: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// Terrain group: worlds of one group share heights and patches (absent: the world is its own group).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<u32>,
}

impl WorldEntry {
    /// The world's terrain group (its own id when the set has no groups).
    pub fn terrain(&self) -> u32 {
        self.terrain.unwrap_or(self.id)
    }
}

/// A patch in a world spec: class, and friction for rigid classes (soil comes from the class).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatchSpec {
    pub class: Semantic,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// A task in a world spec. Paths are full-scale world coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskSpec {
    pub index: u32,
    pub start: [f64; 2],
    pub goal: [f64; 2],
    pub path: Vec<[f64; 2]>,
}

/// `worlds/NNN.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    pub id: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// Terrain group (absent: the world is its own group).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<u32>,
    /// Sample spacing at full scale, m.
    pub cell: f64,
    pub height_min: f64,
    pub height_max: f64,
    /// 16 x 16 patches, row `pi` (along +y, south to north) major.
    pub patches: Vec<PatchSpec>,
    pub obstacles: Vec<Obstacle>,
    pub tasks: Vec<TaskSpec>,
}

/// A generated or imported world with its tasks, at full scale.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldRecord {
    pub world: World,
    pub tasks: Vec<Task>,
    /// Terrain group ([`crate::design`]); `None` when the world is its own group (imported worlds).
    pub terrain: Option<u32>,
}

/// A loaded task set.
#[derive(Clone, Debug)]
pub struct TaskSet {
    pub dir: PathBuf,
    pub manifest: Manifest,
}

fn read(path: &Path) -> Result<Vec<u8>, TasksError> {
    std::fs::read(path).map_err(|e| TasksError::io(path, e))
}

fn world_stem(id: u32) -> String {
    format!("{id:03}")
}
