//! What a run draws from: the task set (a training set unless allowed otherwise), its worlds at the run's scale
//! (loaded once, shared read-only by every episode), their tasks, their obstacle grids for drawing new start/goal
//! pairs, and the vehicle.

use super::{GenerateConfig, GenerateError};
use rayon::prelude::*;
use sim_core::vehicle::VehicleSpec;
use sim_core::world::{Task, World};
use std::sync::Arc;
use tasks::generate::{check_held_out, DEFAULT_SEED};
use tasks::path::{occupancy, DEFAULT_INFLATION};
use tasks::TaskSet;

/// Version (content hash) of the benchmark's committed task set (`tasks/data/v4`; a test checks it).
pub const BENCHMARK_TASK_SET_VERSION: &str = "8e198293bd6cd388";

/// How to make a training set, for messages.
pub const TRAINING_SET_HINT: &str =
    "make a training set from another seed (`vb tasks generate --seed 7 --out \
     out/train-tasks`, or `vertibench.tasks.training()` in Python) and pass its directory";

/// Refuses the benchmark's own task set: its committed version, any set of the benchmark's master seed (its
/// surface counterfactuals share every height, obstacle and task with it), and a set whose seed repeats one of
/// the benchmark's terrain groups. A dataset made on those worlds would train on what the benchmark evaluates.
pub fn check_training_set(set: &TaskSet) -> Result<(), GenerateError> {
    let m = &set.manifest;
    let dir = set.dir.display();
    let why = if m.version == BENCHMARK_TASK_SET_VERSION {
        Some(format!(
            "is the benchmark's task set (version {})",
            m.version
        ))
    } else if m.seed == Some(DEFAULT_SEED) {
        Some(format!(
            "was generated from the benchmark's seed {DEFAULT_SEED} (generator `{}`): its worlds and tasks are the \
             benchmark's",
            m.generator
        ))
    } else if let Some(Err(e)) = m.seed.map(check_held_out) {
        Some(format!("shares worlds with the benchmark ({e})"))
    } else {
        None
    };
    match why {
        None => Ok(()),
        Some(why) => Err(GenerateError::BenchmarkTasks(format!(
            "task set {dir} {why}; a dataset made on it would train on the worlds the benchmark evaluates: \
             {TRAINING_SET_HINT}, or pass --allow-benchmark-tasks to make an analysis-only dataset (marked so in \
             its metadata)"
        ))),
    }
}

/// One world of the set, loaded for a run.
pub struct LoadedWorld {
    /// At the run's scale, shared by every episode on it.
    pub world: Arc<World>,
    /// The set's tasks at the run's scale.
    pub tasks: Vec<Task>,
    /// At full scale with its obstacle grid (obstacles inflated as for the task set's paths): where drawn
    /// start/goal pairs are planned, as the task generator plans its own.
    pub full: World,
    pub blocked: Vec<bool>,
}

/// The task set, its worlds and the vehicle of a run.
pub struct Source {
    pub set: TaskSet,
    /// In world-id order.
    pub worlds: Vec<LoadedWorld>,
    /// The set's tasks as `(position in worlds, task index)`, in (world, task) order.
    pub tasks: Vec<(usize, usize)>,
    pub vehicle: VehicleSpec,
    pub scale: f64,
}

/// The task set, checked ([`check_training_set`] unless `allow_benchmark_tasks`), the vehicle and the scale.
pub fn open(cfg: &GenerateConfig) -> Result<(TaskSet, VehicleSpec, f64), GenerateError> {
    let set = TaskSet::load(&cfg.task_dir)?;
    if !cfg.allow_benchmark_tasks {
        check_training_set(&set)?;
    }
    let vehicle = sim_core::vehicle::vehicle_by_name(&cfg.vehicle)?;
    let scale = cfg.scale.unwrap_or(vehicle.scale);
    if !(scale.is_finite() && scale > 0.0 && scale <= 1.0) {
        return Err(GenerateError::param(
            "scale",
            format!("{scale} must be in (0, 1]"),
        ));
    }
    Ok((set, vehicle, scale))
}

impl Source {
    /// Opens the set ([`open`]) and loads every world, in parallel on the current pool.
    pub fn load(cfg: &GenerateConfig) -> Result<Source, GenerateError> {
        let (set, vehicle, scale) = open(cfg)?;
        let mut ids = set.world_ids();
        ids.sort_unstable();
        if ids.is_empty() {
            return Err(GenerateError::param(
                "task_set",
                format!("{} has no worlds", set.dir.display()),
            ));
        }
        let worlds: Result<Vec<LoadedWorld>, GenerateError> = ids
            .par_iter()
            .map(|&id| {
                let record = set.record(id)?;
                let blocked = occupancy(&record.world, DEFAULT_INFLATION);
                Ok(LoadedWorld {
                    world: Arc::new(record.world.scaled(scale)),
                    tasks: record.tasks.iter().map(|t| t.scaled(scale)).collect(),
                    full: record.world,
                    blocked,
                })
            })
            .collect();
        let worlds = worlds?;
        let tasks = worlds
            .iter()
            .enumerate()
            .flat_map(|(w, lw)| (0..lw.tasks.len()).map(move |t| (w, t)))
            .collect();
        Ok(Source {
            set,
            worlds,
            tasks,
            vehicle,
            scale,
        })
    }
}
