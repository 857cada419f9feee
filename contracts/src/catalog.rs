//! The benchmark as the service tier sees it, without the simulator: the simulator version results must carry, the
//! task set's version and each world's factors, the vehicles a submission may name and the built-in planners. The
//! binary that wires the services builds it (`eval::catalog` from `tasks`, `sim-core` and `baselines`) and passes
//! it in, so the coordinator, the store and the leaderboard never link the physics.
//!
//! Task selection (`--tasks` of `vb eval`, `vb-submit` and the Python SDK) is here too: it reads only the factors.

use crate::{
    ElevationLevel, ObstacleDensity, PerceptionId, PlannerName, SemanticsKind, SimVersion, TaskId,
    VehicleId,
};
use std::collections::{BTreeMap, BTreeSet};

/// Start/goal pairs of every world.
pub const TASKS_PER_WORLD: u32 = 10;

/// A world's design factors and its terrain group (worlds of one group share heights and patches and differ only in
/// obstacle density; `None` for sets without groups, such as imported worlds).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WorldFacts {
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    pub terrain: Option<u32>,
}

/// See the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct Catalog {
    /// The simulator every result must have been produced with.
    pub sim_version: SimVersion,
    pub task_set_version: String,
    pub worlds: BTreeMap<u32, WorldFacts>,
    /// The vehicles a submission may name, each with its own scale.
    pub vehicles: BTreeMap<VehicleId, f64>,
    /// Names of the built-in planners.
    pub builtin_planners: Vec<PlannerName>,
    /// The perception profiles a submission may name, by name (`ideal`, `nominal`, `degraded`).
    pub perception: BTreeMap<String, CatalogProfile>,
    /// The built-in planners that run under a profile that degrades the maps (they read no ground-truth maps, or
    /// read the believed world); the others run under ground-truth maps only.
    pub belief_planners: Vec<PlannerName>,
}

/// A perception profile as the service carries it: its identity, and its parameters as the `perception` crate's
/// canonical JSON (empty for `ideal`), which workers parse.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PerceptionEntry {
    pub id: PerceptionId,
    pub params: String,
}

/// A profile of the catalogue.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CatalogProfile {
    pub entry: PerceptionEntry,
    /// The profile degrades the maps (an online elevation map, semantic or obstacle errors).
    pub degrades_maps: bool,
}

impl Catalog {
    /// Every task, in id order.
    pub fn all_tasks(&self) -> Vec<TaskId> {
        all(&self.worlds)
    }

    /// The tasks a selection names (see [`select`]).
    pub fn select(&self, spec: &str) -> Result<Vec<TaskId>, SelectionError> {
        select(&self.worlds, spec)
    }

    /// The profile a submission names (empty: `ideal`), or the names there are.
    pub fn perception_profile(&self, name: &str) -> Result<CatalogProfile, String> {
        let name = if name.is_empty() { "ideal" } else { name };
        if name == "ideal" {
            return Ok(CatalogProfile::default());
        }
        self.perception.get(name).cloned().ok_or_else(|| {
            let mut names: Vec<&str> = self.perception.keys().map(|k| k.as_str()).collect();
            if !names.contains(&"ideal") {
                names.insert(0, "ideal");
            }
            format!(
                "unknown perception profile `{name}` (this service runs: {})",
                names.join(", ")
            )
        })
    }

    /// The terrain group of `world` when results of `task_set_version` are read against this catalog.
    pub fn terrain(&self, task_set_version: &str, world: u32) -> Option<u32> {
        (task_set_version == self.task_set_version)
            .then(|| self.worlds.get(&world).and_then(|w| w.terrain))
            .flatten()
    }
}

/// A world as pages draw it: a PNG of its map (`ppm` pixels per heightmap sample, north up), the heightmap's size
/// and sample spacing (m), and each task's start, goal and global path (full scale, m, world frame centred on the
/// map). Made by `tasks::TaskSet::world_picture`.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldPicture {
    pub png: Vec<u8>,
    pub ppm: u32,
    pub nx: usize,
    pub ny: usize,
    pub cell: f64,
    pub tasks: Vec<TaskGeometry>,
}

/// Where a task starts and ends, and its global path (m).
#[derive(Clone, Debug, PartialEq)]
pub struct TaskGeometry {
    pub start: [f64; 2],
    pub goal: [f64; 2],
    pub path: Vec<[f64; 2]>,
}

impl WorldPicture {
    /// Picture pixel of full-scale world position `(x, y)` (the heightmap's sample grid, centred, y up).
    pub fn pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let fx = x / self.cell + (self.nx - 1) as f64 * 0.5;
        let fy = y / self.cell + (self.ny - 1) as f64 * 0.5;
        let ppm = f64::from(self.ppm);
        ((fx + 0.5) * ppm, (self.ny as f64 - 1.0 - fy + 0.5) * ppm)
    }
}

/// A selection that names nothing in the task set, or is not a selection.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct SelectionError(pub String);

/// Named splits for selections: every task of the worlds with one factor level. An item list is a union
/// (`low,dense` = the low worlds and the dense worlds); `+` intersects (`low+rigid` = the low rigid worlds).
pub const SPLITS: [&str; 9] = [
    "low",
    "medium",
    "high",
    "rigid",
    "deformable",
    "mixed",
    "sparse",
    "medium-density",
    "dense",
];

/// Whether a world with these factors belongs to a named split.
fn in_split(w: &WorldFacts, split: &str) -> bool {
    match split {
        "medium-density" => w.density == ObstacleDensity::Medium,
        "sparse" | "dense" => w.density.as_str() == split,
        "rigid" | "deformable" | "mixed" => w.semantics.as_str() == split,
        _ => w.level.as_str() == split,
    }
}

fn all(worlds: &BTreeMap<u32, WorldFacts>) -> Vec<TaskId> {
    worlds
        .keys()
        .flat_map(|&w| (0..TASKS_PER_WORLD).map(move |t| TaskId::new(w, t)))
        .collect()
}

/// The tasks of `worlds` that `spec` names: `all`, or the union of its comma-separated items (world ids, task ids
/// such as `w017-t3`, [`SPLITS`] and splits joined by `+`), each task once, in id order.
pub fn select(
    worlds: &BTreeMap<u32, WorldFacts>,
    spec: &str,
) -> Result<Vec<TaskId>, SelectionError> {
    if spec.trim() == "all" {
        return Ok(all(worlds));
    }
    // A union: items may repeat or overlap (`all,all`, `low,w001-t0`); each task is selected once.
    let mut out = BTreeSet::new();
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        if item == "all" {
            out.extend(all(worlds));
            continue;
        }
        let bad = || {
            SelectionError(format!(
                "`{item}` is not `all`, a world id, a task id like w017-t3, a split ({}) or splits joined by `+` (low+rigid: both)",
                SPLITS.join(", ")
            ))
        };
        let parts: Vec<&str> = item.split('+').map(str::trim).collect();
        if parts.iter().all(|p| SPLITS.contains(p)) {
            // `low+rigid`: the worlds in every one of the splits.
            for (&w, facts) in worlds {
                if parts.iter().all(|p| in_split(facts, p)) {
                    out.extend((0..TASKS_PER_WORLD).map(|t| TaskId::new(w, t)));
                }
            }
        } else if item.starts_with('w') {
            let id: TaskId = item.parse().map_err(|_| bad())?;
            if !worlds.contains_key(&id.world) || id.index >= TASKS_PER_WORLD {
                return Err(SelectionError(format!(
                    "task `{item}` is not in the task set"
                )));
            }
            out.insert(id);
        } else {
            let w: u32 = item.parse().map_err(|_| bad())?;
            if !worlds.contains_key(&w) {
                return Err(SelectionError(format!("world {w} is not in the task set")));
            }
            out.extend((0..TASKS_PER_WORLD).map(|t| TaskId::new(w, t)));
        }
    }
    if out.is_empty() {
        return Err(SelectionError("no task selected".into()));
    }
    Ok(out.into_iter().collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn worlds() -> BTreeMap<u32, WorldFacts> {
        let f = |level, semantics, density| WorldFacts {
            level,
            semantics,
            density,
            terrain: Some(1),
        };
        use ElevationLevel::*;
        BTreeMap::from([
            (1, f(Low, SemanticsKind::Rigid, ObstacleDensity::Sparse)),
            (2, f(Low, SemanticsKind::Mixed, ObstacleDensity::Medium)),
            (7, f(High, SemanticsKind::Rigid, ObstacleDensity::Dense)),
        ])
    }

    #[test]
    fn selections_are_unions_of_items_and_intersections_of_splits() {
        let w = worlds();
        let all = select(&w, "all").unwrap();
        assert_eq!(all.len(), 30);
        assert_eq!(select(&w, "all,all").unwrap(), all);
        assert_eq!(select(&w, " all , low ,all").unwrap(), all);
        assert_eq!(
            select(&w, "w001-t3,w001-t3,1").unwrap(),
            select(&w, "1").unwrap()
        );
        let ids = |s: &str| {
            select(&w, s)
                .unwrap()
                .iter()
                .map(|t| t.world)
                .collect::<BTreeSet<_>>()
        };
        assert_eq!(ids("low+rigid"), BTreeSet::from([1]));
        assert_eq!(ids("medium-density,dense"), BTreeSet::from([2, 7]));
        let e = select(&w, "all,banana").unwrap_err().to_string();
        assert!(e.contains("`banana` is not `all`"), "{e}");
        assert_eq!(
            select(&w, "w003-t0").unwrap_err().to_string(),
            "task `w003-t0` is not in the task set"
        );
        assert_eq!(
            select(&w, "w001-t10").unwrap_err().to_string(),
            "task `w001-t10` is not in the task set"
        );
        assert_eq!(
            select(&w, "medium").unwrap_err().to_string(),
            "no task selected"
        );
    }
}
