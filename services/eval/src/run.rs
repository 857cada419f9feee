//! Running the episodes of an evaluation, resumably.

use crate::{io_err, EvalError};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use sim_core::episode::{EpisodeConfig, EpisodeMetrics, Rules};
use sim_core::planner::Planner;
use std::collections::BTreeSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;
use tasks::TaskSet;

/// Version of the simulator recorded with every result.
pub use sim_core::SIM_VERSION;

/// What to evaluate.
#[derive(Clone, Debug)]
pub struct EvalConfig {
    pub planner: String,
    pub task_dir: PathBuf,
    /// `all`, or a comma-separated list of world ids (`17`), task ids (`w017-t3`) and named splits ([`SPLITS`]).
    pub tasks: String,
    pub vehicle: String,
    /// World scale; `None` = the vehicle's own scale.
    pub scale: Option<f64>,
    pub out: PathBuf,
    pub episode: EpisodeConfig,
}

/// One finished episode: task factors, outcome, every metric and what makes it reproducible.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeRow {
    pub task_id: String,
    pub world_id: u32,
    pub task_index: u32,
    pub level: String,
    pub semantics: String,
    pub density: String,
    /// Terrain group of the world: worlds of one group share heights and patches and differ only in obstacle
    /// density (nested layouts). `None` for sets without groups (imported worlds).
    #[serde(default)]
    pub terrain: Option<u32>,
    pub planner: String,
    pub vehicle: String,
    pub scale: f64,
    pub seed: u64,
    pub task_set_version: String,
    pub sim_version: String,
    /// The episode rules (`--release-rules`: release); older rows without it followed the paper's.
    #[serde(default)]
    pub rules: Rules,
    pub outcome: String,
    pub reason: String,
    pub detail: String,
    pub metrics: EpisodeMetrics,
    pub wall_time_s: f64,
}

#[cfg(test)]
impl EpisodeRow {
    /// A PID episode with the HMMWV on a low, rigid, sparse world of task set `v`, for unit tests to override field
    /// by field.
    pub(crate) fn for_test(task_id: &str, outcome: &str) -> Self {
        EpisodeRow {
            task_id: task_id.into(),
            world_id: 1,
            task_index: 0,
            level: "low".into(),
            semantics: "rigid".into(),
            density: "sparse".into(),
            terrain: None,
            planner: "pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            task_set_version: "v".into(),
            sim_version: "s".into(),
            rules: Default::default(),
            outcome: outcome.into(),
            reason: String::new(),
            detail: String::new(),
            metrics: EpisodeMetrics::default(),
            wall_time_s: 0.1,
        }
    }
}

/// Named splits of the task set for `--tasks`: every task of the worlds with one factor level. An item list is a
/// union (`low,dense` = the low worlds and the dense worlds); `+` intersects (`low+rigid` = the low rigid worlds).
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
fn in_split(w: &tasks::format::WorldEntry, split: &str) -> bool {
    match split {
        "medium-density" => w.density.as_str() == "medium",
        "sparse" | "dense" => w.density.as_str() == split,
        "rigid" | "deformable" | "mixed" => w.semantics.as_str() == split,
        _ => w.level.as_str() == split,
    }
}

/// Selects `(world id, task index)` pairs from a task set.
pub fn select(set: &TaskSet, spec: &str) -> Result<Vec<(u32, u32)>, EvalError> {
    let ids = set.world_ids();
    let all = || {
        ids.iter()
            .flat_map(|&w| (0..10).map(move |t| (w, t)))
            .collect::<Vec<_>>()
    };
    if spec.trim() == "all" {
        return Ok(all());
    }
    let mut out = BTreeSet::new();
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let bad = || {
            EvalError::Param {
            field: "tasks".into(),
            message: format!(
                "`{item}` is not `all`, a world id, a task id like w017-t3, a split ({}) or splits joined by `+` (low+rigid: both)",
                SPLITS.join(", ")
            ),
        }
        };
        let parts: Vec<&str> = item.split('+').map(str::trim).collect();
        if parts.iter().all(|p| SPLITS.contains(p)) {
            // `low+rigid`: the worlds in every one of the splits.
            for &w in &ids {
                let meta = set.world_meta(w)?;
                if parts.iter().all(|p| in_split(meta, p)) {
                    out.extend((0..10).map(|t| (w, t)));
                }
            }
        } else if let Some(rest) = item.strip_prefix('w') {
            let (w, t) = rest.split_once("-t").ok_or_else(bad)?;
            let (w, t): (u32, u32) = (w.parse().map_err(|_| bad())?, t.parse().map_err(|_| bad())?);
            if !ids.contains(&w) || t >= 10 {
                return Err(EvalError::Param {
                    field: "tasks".into(),
                    message: format!("task `{item}` is not in the task set"),
                });
            }
            out.insert((w, t));
        } else {
            let w: u32 = item.parse().map_err(|_| bad())?;
            if !ids.contains(&w) {
                return Err(EvalError::Param {
                    field: "tasks".into(),
                    message: format!("world {w} is not in the task set"),
                });
            }
            out.extend((0..10).map(|t| (w, t)));
        }
    }
    if out.is_empty() {
        return Err(EvalError::Param {
            field: "tasks".into(),
            message: "no task selected".into(),
        });
    }
    Ok(out.into_iter().collect())
}

/// Reads the finished rows of `results.jsonl` (a torn last line is ignored).
pub fn read_results(path: &Path) -> Result<Vec<EpisodeRow>, EvalError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io_err(path, e)),
    };
    let mut rows = Vec::new();
    let mut seen = BTreeSet::new();
    let lines: Vec<&str> = text.lines().collect();
    for (i, line) in lines.iter().enumerate() {
        match serde_json::from_str::<EpisodeRow>(line) {
            Ok(r) => {
                if seen.insert(r.task_id.clone()) {
                    rows.push(r);
                }
            }
            Err(_) if i + 1 == lines.len() && !text.ends_with('\n') => {}
            Err(e) => return Err(io_err(path, format!("line {}: {e}", i + 1))),
        }
    }
    Ok(rows)
}

/// Progress callback: (done, total, seconds elapsed).
pub type Progress<'a> = &'a (dyn Fn(usize, usize, f64) + Sync);

/// Makes a fresh planner for one episode.
pub type PlannerFactory<'a> = &'a (dyn Fn() -> Box<dyn Planner> + Sync);

/// Runs (or resumes) an evaluation of the built-in planner `cfg.planner` and returns every row of it.
pub fn run(cfg: &EvalConfig, progress: Progress<'_>) -> Result<Vec<EpisodeRow>, EvalError> {
    if baselines::by_name(&cfg.planner).is_none() {
        return Err(EvalError::Param {
            field: "planner".into(),
            message: format!(
                "unknown planner `{}` (built-in: {})",
                cfg.planner,
                baselines::NAMES.join(", ")
            ),
        });
    }
    let make = || baselines::by_name(&cfg.planner).expect("checked above");
    run_with(cfg, &make, &AtomicBool::new(false), progress)
}

/// Runs (or resumes) an evaluation of the planners `make` returns (one per episode; the rows are labelled
/// `cfg.planner`), in parallel on the current rayon pool. Once `cancel` is set no new episode starts and the ones
/// that finish are not recorded, so a resumed evaluation runs them again; the rows recorded so far are returned.
pub fn run_with(
    cfg: &EvalConfig,
    make: PlannerFactory<'_>,
    cancel: &AtomicBool,
    progress: Progress<'_>,
) -> Result<Vec<EpisodeRow>, EvalError> {
    let vehicle = sim_core::vehicle::vehicle_by_name(&cfg.vehicle)?;
    let scale = cfg.scale.unwrap_or(vehicle.scale);
    if !(scale.is_finite() && scale > 0.0) {
        return Err(EvalError::Param {
            field: "scale".into(),
            message: format!("{scale} is not positive"),
        });
    }
    let set = TaskSet::load(&cfg.task_dir)?;
    let selected = select(&set, &cfg.tasks)?;
    std::fs::create_dir_all(&cfg.out).map_err(|e| io_err(&cfg.out, e))?;
    let results_path = cfg.out.join("results.jsonl");
    let mut rows = read_results(&results_path)?;
    // A crash can leave a torn last line: cut it off before appending, so new lines start on a line of their own.
    if let Ok(text) = std::fs::read_to_string(&results_path) {
        if !text.is_empty() && !text.ends_with('\n') {
            let keep = text.rfind('\n').map_or(0, |i| i + 1);
            std::fs::write(&results_path, &text[..keep]).map_err(|e| io_err(&results_path, e))?;
        }
    }
    // Rows of another configuration cannot be mixed in.
    if let Some(r) = rows.first() {
        if r.planner != cfg.planner
            || r.vehicle != vehicle.name
            || (r.scale - scale).abs() > 1e-12
            || r.task_set_version != set.version()
            || r.sim_version != SIM_VERSION
            || r.rules != cfg.episode.rules()
        {
            return Err(EvalError::Param {
                field: "out".into(),
                message: format!("{} holds results of planner {} / vehicle {} / scale {} / task set {} / {} / {} rules; use another --out", results_path.display(), r.planner, r.vehicle, r.scale, r.task_set_version, r.sim_version, r.rules.as_str()),
            });
        }
    }
    let done: BTreeSet<String> = rows.iter().map(|r| r.task_id.clone()).collect();
    let todo: Vec<(u32, u32)> = selected
        .iter()
        .copied()
        .filter(|(w, t)| !done.contains(&format!("w{w:03}-t{t}")))
        .collect();
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&results_path)
        .map_err(|e| io_err(&results_path, e))?;
    let file = Mutex::new(file);
    let total = selected.len();
    let finished = AtomicUsize::new(total - todo.len());
    let start = Instant::now();
    let new_rows: Vec<Result<Option<EpisodeRow>, EvalError>> = todo
        .par_iter()
        .map(|&(w, t)| {
            if cancel.load(Ordering::SeqCst) {
                return Ok(None);
            }
            let world = set.world(w, scale)?;
            let task = set
                .tasks(w, scale)?
                .into_iter()
                .nth(t as usize)
                .ok_or(tasks::TasksError::UnknownWorld(w))?;
            let mut planner = make();
            let t0 = Instant::now();
            let r = sim_core::run_episode(&world, &task, &vehicle, planner.as_mut(), &cfg.episode);
            if cancel.load(Ordering::SeqCst) {
                return Ok(None);
            }
            let row = EpisodeRow {
                task_id: task.id(),
                world_id: w,
                task_index: t,
                level: world.level.as_str().into(),
                semantics: world.semantics.as_str().into(),
                density: world.density.as_str().into(),
                terrain: set.world_meta(w)?.terrain,
                planner: cfg.planner.clone(),
                vehicle: vehicle.name.clone(),
                scale,
                seed: cfg.episode.seed,
                task_set_version: set.version().into(),
                sim_version: SIM_VERSION.into(),
                rules: cfg.episode.rules(),
                outcome: r.outcome.as_str().into(),
                reason: r.reason,
                detail: r.detail,
                metrics: r.metrics,
                wall_time_s: t0.elapsed().as_secs_f64(),
            };
            let line = serde_json::to_string(&row).map_err(|e| io_err(&results_path, e))? + "\n";
            {
                let mut f = file
                    .lock()
                    .map_err(|_| io_err(&results_path, "results file lock poisoned"))?;
                f.write_all(line.as_bytes())
                    .and_then(|_| f.flush())
                    .map_err(|e| io_err(&results_path, e))?;
            }
            let n = finished.fetch_add(1, Ordering::SeqCst) + 1;
            progress(n, total, start.elapsed().as_secs_f64());
            Ok(Some(row))
        })
        .collect();
    for r in new_rows {
        rows.extend(r?);
    }
    let keep: BTreeSet<String> = selected
        .iter()
        .map(|(w, t)| format!("w{w:03}-t{t}"))
        .collect();
    rows.retain(|r| keep.contains(&r.task_id));
    rows.sort_by_key(|r| (r.world_id, r.task_index));
    Ok(rows)
}
