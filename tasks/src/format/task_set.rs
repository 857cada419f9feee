//! Opening a task set ([`TaskSet::load`]: manifest, version and every world file checked) and loading its worlds.

use super::world_file::{load_record, read_spec};
use super::{content_version, read, Manifest, TaskSet, WorldEntry, WorldRecord, FORMAT};
use crate::TasksError;
use sim_core::world::{Task, World};
use std::path::{Path, PathBuf};

impl TaskSet {
    /// The committed task set of this repository.
    pub fn default_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data")
            .join("v4")
    }

    /// Opens the committed task set ([`TaskSet::default_dir`]).
    pub fn committed() -> Result<TaskSet, TasksError> {
        Self::load(&Self::default_dir())
    }

    /// Opens a task set directory: reads and validates the manifest, and recomputes the version from the world
    /// files, refusing a set whose files do not hash to the version its manifest claims (results carry the
    /// version, so it must say what they were computed on), and checks every world file's numbers against their
    /// physical ranges ([`crate::check`]).
    pub fn load(dir: &Path) -> Result<TaskSet, TasksError> {
        let path = dir.join("manifest.json");
        let bytes = read(&path)?;
        let manifest: Manifest = serde_json::from_slice(&bytes).map_err(|e| TasksError::Json {
            path: path.clone(),
            source: e,
        })?;
        if manifest.format != FORMAT {
            return Err(TasksError::field(
                &path,
                "format",
                format!(
                    "unsupported format `{}`, expected `{FORMAT}`",
                    manifest.format
                ),
            ));
        }
        let mut ids: Vec<u32> = manifest.worlds.iter().map(|w| w.id).collect();
        ids.sort_unstable();
        if ids.windows(2).any(|w| w[0] == w[1]) {
            return Err(TasksError::field(&path, "worlds", "duplicate world id"));
        }
        let actual = content_version(dir, &manifest)?;
        if actual != manifest.version {
            return Err(TasksError::field(
                &path,
                "version",
                format!(
                    "the manifest says `{}` but the world files hash to `{actual}`: the task set was changed after \
                     it was written; restore its files or regenerate it (`vb tasks generate`)",
                    manifest.version
                ),
            ));
        }
        // Every world file's numbers in their physical ranges, so a bad set is refused when opened, not mid-run.
        for w in &manifest.worlds {
            read_spec(&dir.join("worlds"), w.id)?;
        }
        Ok(TaskSet {
            dir: dir.to_path_buf(),
            manifest,
        })
    }

    /// The task-set version (content hash).
    pub fn version(&self) -> &str {
        &self.manifest.version
    }

    pub fn world_ids(&self) -> Vec<u32> {
        self.manifest.worlds.iter().map(|w| w.id).collect()
    }

    /// Factors of a world without loading it.
    pub fn world_meta(&self, id: u32) -> Result<&WorldEntry, TasksError> {
        self.manifest
            .worlds
            .iter()
            .find(|w| w.id == id)
            .ok_or(TasksError::UnknownWorld(id))
    }

    /// Loads one world at full scale with its tasks.
    pub fn record(&self, id: u32) -> Result<WorldRecord, TasksError> {
        self.world_meta(id)?;
        load_record(&self.dir.join("worlds"), id)
    }

    /// A world instantiated at `scale` (1, 1/6, 1/10, ...).
    pub fn world(&self, id: u32, scale: f64) -> Result<World, TasksError> {
        check_scale(scale)?;
        Ok(self.record(id)?.world.scaled(scale))
    }

    /// The tasks of a world at `scale`.
    pub fn tasks(&self, world_id: u32, scale: f64) -> Result<Vec<Task>, TasksError> {
        check_scale(scale)?;
        Ok(self
            .record(world_id)?
            .tasks
            .iter()
            .map(|t| t.scaled(scale))
            .collect())
    }

    /// Every world record, in id order.
    pub fn records(&self) -> Result<Vec<WorldRecord>, TasksError> {
        self.world_ids()
            .into_iter()
            .map(|id| self.record(id))
            .collect()
    }
}

fn check_scale(scale: f64) -> Result<(), TasksError> {
    if scale.is_finite() && scale > 0.0 && scale <= 10.0 {
        Ok(())
    } else {
        Err(TasksError::Param {
            field: "scale".into(),
            message: format!("{scale} is not in (0, 10]"),
        })
    }
}
