//! Running the episodes of an evaluation, resumably.

use crate::{io_err, EpisodeRow, EvalError};
use contracts::{RecordedOutcome, TaskId};
use rayon::prelude::*;
use sim_core::episode::EpisodeConfig;
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

// Task selection (`--tasks`) is the task set's: one parser for `vb eval`, the service and Python.
pub use tasks::selection::{select, SPLITS};

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
                if seen.insert(r.task_id) {
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
    let done: BTreeSet<TaskId> = rows.iter().map(|r| r.task_id).collect();
    let todo: Vec<(u32, u32)> = selected
        .iter()
        .copied()
        .filter(|&(w, t)| !done.contains(&TaskId::new(w, t)))
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
                task_id: TaskId::new(w, t),
                world_id: w,
                task_index: t,
                level: world.level,
                semantics: world.semantics,
                density: world.density,
                terrain: set.world_meta(w)?.terrain,
                planner: cfg.planner.clone(),
                vehicle: vehicle.name.clone(),
                scale,
                seed: cfg.episode.seed,
                task_set_version: set.version().into(),
                sim_version: SIM_VERSION.into(),
                rules: cfg.episode.rules(),
                outcome: RecordedOutcome::Episode(r.outcome),
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
    let keep: BTreeSet<TaskId> = selected.iter().map(|&(w, t)| TaskId::new(w, t)).collect();
    rows.retain(|r| keep.contains(&r.task_id));
    rows.sort_by_key(|r| (r.world_id, r.task_index));
    Ok(rows)
}
