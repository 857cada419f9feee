//! Where environments get their episodes: a task set directory, a selection of its tasks, the worlds those tasks
//! need (loaded once, shared read-only by every environment), the vehicle and the episode rules.

use rayon::prelude::*;
use sim_core::episode::EpisodeConfig;
use sim_core::vehicle::VehicleSpec;
use sim_core::world::{Task, World};
use sim_core::EpisodeRun;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::{Arc, OnceLock};
use tasks::TaskSet;

/// One world with its tasks, at the episode's scale.
pub struct LoadedWorld {
    pub world: World,
    pub tasks: Vec<Task>,
    pub level: &'static str,
    pub semantics: &'static str,
    pub density: &'static str,
}

/// The episodes environments draw from.
pub struct Source {
    pub version: String,
    /// Selected `(world id, task index)` pairs, in task-id order.
    pub tasks: Vec<(u32, u32)>,
    pub worlds: BTreeMap<u32, Arc<LoadedWorld>>,
    pub vehicle: VehicleSpec,
    pub scale: f64,
    pub episode: EpisodeConfig,
    /// Each selected task's episode at its start (settled), made on first use and cloned at every reset: the
    /// start's settling (a few simulated seconds) is computed once per task. A clone is bit-identical to a fresh
    /// start. A rigid world's start holds about 150 kB; a soil world's reserves its soil pool but touches little.
    starts: Vec<OnceLock<EpisodeRun>>,
}

impl Source {
    /// Loads the worlds of the tasks that `spec` selects (as `vb eval --tasks`: `all`, splits, world and task ids).
    pub fn load(
        dir: &Path,
        spec: &str,
        vehicle: &str,
        scale: Option<f64>,
        episode: EpisodeConfig,
    ) -> Result<Source, String> {
        let set = TaskSet::load(dir).map_err(|e| e.to_string())?;
        let tasks = eval::run::select(&set, spec).map_err(|e| e.to_string())?;
        let vehicle = sim_core::vehicle::vehicle_by_name(vehicle).map_err(|e| e.to_string())?;
        let scale = scale.unwrap_or(vehicle.scale);
        if !(scale.is_finite() && scale > 0.0 && scale <= 1.0) {
            return Err(format!("scale {scale} must be in (0, 1]"));
        }
        let mut ids: Vec<u32> = tasks.iter().map(|t| t.0).collect();
        ids.dedup();
        let loaded: Result<Vec<(u32, Arc<LoadedWorld>)>, String> = ids
            .par_iter()
            .map(|&w| {
                let world = set.world(w, scale).map_err(|e| e.to_string())?;
                let tasks = set.tasks(w, scale).map_err(|e| e.to_string())?;
                let lw = LoadedWorld {
                    level: world.level.as_str(),
                    semantics: world.semantics.as_str(),
                    density: world.density.as_str(),
                    world,
                    tasks,
                };
                Ok((w, Arc::new(lw)))
            })
            .collect();
        Ok(Source {
            version: set.version().to_string(),
            starts: (0..tasks.len()).map(|_| OnceLock::new()).collect(),
            tasks,
            worlds: loaded?.into_iter().collect(),
            vehicle,
            scale,
            episode,
        })
    }

    /// A new episode on selected task `k`, at its settled start.
    pub fn start(&self, k: usize) -> EpisodeRun {
        self.starts[k]
            .get_or_init(|| {
                let (lw, t) = self.get(k);
                EpisodeRun::new(&lw.world, t, &self.vehicle, &self.episode)
            })
            .clone()
    }

    /// The world and task of selected task `k`.
    pub fn get(&self, k: usize) -> (&Arc<LoadedWorld>, &Task) {
        let (w, t) = self.tasks[k];
        let lw = &self.worlds[&w];
        (lw, &lw.tasks[t as usize])
    }
}
