//! Running the episodes of an evaluation, resumably.

use crate::identity::{self, PlannerIdentity};
use crate::{io_err, Builtin, EpisodeRow, EvalError};
use contracts::{RecordedOutcome, TaskId};
use rayon::prelude::*;
use sim_core::episode::EpisodeConfig;
use sim_core::planner::{Action, Planner, VehicleState};
use sim_core::vehicle::VehicleSpec;
use sim_core::EpisodeObserver;
use std::collections::BTreeSet;
use std::io::Write;
use std::ops::ControlFlow;
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
    /// The planner's label in the rows: a built-in's name (for [`run`]) or the planner's own `name`.
    pub planner: contracts::PlannerName,
    /// Which planner runs, checked against the `planner.json` of `out` on resume; `None`: the built-in `planner`.
    pub identity: Option<PlannerIdentity>,
    pub task_dir: PathBuf,
    /// `all`, or a comma-separated list of world ids (`17`), task ids (`w017-t3`) and named splits ([`SPLITS`]).
    pub tasks: String,
    pub vehicle: contracts::VehicleId,
    /// World scale; `None` = the vehicle's own scale.
    pub scale: Option<f64>,
    pub out: PathBuf,
    /// How the caller names `out` in messages: `--out` (`vb eval`), `out=` (Python).
    pub out_param: String,
    pub episode: EpisodeConfig,
    /// What the planner perceives (`Profile::ideal()`: the truth, as always).
    pub perception: perception::Profile,
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
pub type ProgressFn<'a> = &'a (dyn Fn(usize, usize, f64) + Sync);

/// Makes a fresh planner for one episode.
pub type PlannerFactory<'a> = &'a (dyn Fn() -> Box<dyn Planner> + Sync);

/// Runs (or resumes) an evaluation of the built-in planner `cfg.planner` and returns every row of it.
pub fn run(cfg: &EvalConfig, progress: ProgressFn<'_>) -> Result<Vec<EpisodeRow>, EvalError> {
    let builtin = Builtin::resolve(&cfg.planner, None)?;
    run_builtin(cfg, &builtin, progress)
}

/// Runs (or resumes) an evaluation of a resolved built-in planner (say, a learned one with a weights file); the rows
/// are labelled `cfg.planner`.
pub fn run_builtin(
    cfg: &EvalConfig,
    builtin: &Builtin,
    progress: ProgressFn<'_>,
) -> Result<Vec<EpisodeRow>, EvalError> {
    let make = || builtin.make();
    if cfg.identity.is_some() {
        return run_with(cfg, &make, &AtomicBool::new(false), progress);
    }
    let cfg = EvalConfig {
        identity: Some(PlannerIdentity::of_builtin(builtin)),
        ..cfg.clone()
    };
    run_with(&cfg, &make, &AtomicBool::new(false), progress)
}

/// An error unless `name` is a built-in planner this build can run.
pub fn check_builtin(name: &str) -> Result<(), EvalError> {
    Builtin::resolve(name, None)?;
    Ok(())
}

/// Runs (or resumes) an evaluation of the planners `make` returns (one per episode; the rows are labelled
/// `cfg.planner`), in parallel on the current rayon pool: [`prepare`], then [`Prepared::run`].
pub fn run_with(
    cfg: &EvalConfig,
    make: PlannerFactory<'_>,
    cancel: &AtomicBool,
    progress: ProgressFn<'_>,
) -> Result<Vec<EpisodeRow>, EvalError> {
    prepare(cfg)?.run(make, cancel, progress)
}

/// An evaluation ready to run: its parameters checked, the rows it keeps from `results.jsonl` read and checked
/// against its configuration and planner, `planner.json` written and `results.jsonl` open for appending.
pub struct Prepared<'a> {
    cfg: &'a EvalConfig,
    vehicle: VehicleSpec,
    scale: f64,
    set: TaskSet,
    selected: Vec<(u32, u32)>,
    rows: Vec<EpisodeRow>,
    todo: Vec<(u32, u32)>,
    results_path: PathBuf,
    file: std::fs::File,
}

/// Checks `cfg` and what its output directory holds, and prepares the evaluation (see [`Prepared`]).
pub fn prepare(cfg: &EvalConfig) -> Result<Prepared<'_>, EvalError> {
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
    let rows = read_results(&results_path)?;
    let again = |what: String| EvalError::Param {
        field: "out".into(),
        message: format!(
            "{} holds results of {what}; use another {} (or delete it)",
            cfg.out.display(),
            cfg.out_param
        ),
    };
    // Rows of another configuration cannot be mixed in.
    if let Some(r) = rows.first() {
        if r.planner != cfg.planner
            || r.vehicle != vehicle.name
            || (r.scale - scale).abs() > 1e-12
            || r.task_set_version != set.version()
            || r.sim_version != SIM_VERSION
            || r.rules != cfg.episode.rules()
            || r.perception != cfg.perception.id()
        {
            return Err(again(format!(
                "planner {} / vehicle {} / scale {} / task set {} / {} / {} rules / perception {}",
                r.planner,
                r.vehicle,
                r.scale,
                r.task_set_version,
                r.sim_version,
                r.rules.as_str(),
                r.perception
            )));
        }
    }
    // Nor rows of another planner under the same label.
    let identity = cfg
        .identity
        .clone()
        .unwrap_or_else(|| PlannerIdentity::builtin(&cfg.planner));
    if !rows.is_empty() {
        if let Some(stored) = identity::read(&cfg.out)? {
            if !stored.same(&identity) {
                return Err(again(stored.difference(&identity)));
            }
        }
    }
    identity::write(&cfg.out, &identity)?;
    // A crash can leave a torn last line: cut it off before appending, so new lines start on a line of their own.
    if let Ok(text) = std::fs::read_to_string(&results_path) {
        if !text.is_empty() && !text.ends_with('\n') {
            let keep = text.rfind('\n').map_or(0, |i| i + 1);
            std::fs::write(&results_path, &text[..keep]).map_err(|e| io_err(&results_path, e))?;
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
    Ok(Prepared {
        cfg,
        vehicle,
        scale,
        set,
        selected,
        rows,
        todo,
        results_path,
        file,
    })
}

/// Stops an episode at its next control step once the evaluation is cancelled.
struct CancelOnFlag<'a>(&'a AtomicBool);

impl EpisodeObserver for CancelOnFlag<'_> {
    fn on_control_step(&mut self, _: &VehicleState, _: &Action) -> ControlFlow<()> {
        if self.0.load(Ordering::SeqCst) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

impl Prepared<'_> {
    /// Episodes of the selection whose results `out` already holds (a resumed evaluation keeps them).
    pub fn kept(&self) -> usize {
        self.selected.len() - self.todo.len()
    }

    /// Episodes of the selection.
    pub fn total(&self) -> usize {
        self.selected.len()
    }

    /// Runs the episodes left, in parallel on the current rayon pool, each with a planner from `make`, and returns
    /// every row of the selection. Once `cancel` is set no new episode starts, the running ones stop at their next
    /// control step and are not recorded (a resumed evaluation runs them again); the rows recorded so far are
    /// returned.
    pub fn run(
        self,
        make: PlannerFactory<'_>,
        cancel: &AtomicBool,
        progress: ProgressFn<'_>,
    ) -> Result<Vec<EpisodeRow>, EvalError> {
        let Prepared {
            cfg,
            vehicle,
            scale,
            set,
            selected,
            mut rows,
            todo,
            results_path,
            file,
        } = self;
        refuse_map_reading(cfg, make)?;
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
                let Some(row) =
                    run_task(cfg, &set, &vehicle, scale, make, cancel, TaskId::new(w, t))?
                else {
                    return Ok(None);
                };
                let line =
                    serde_json::to_string(&row).map_err(|e| io_err(&results_path, e))? + "\n";
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
}

/// A map-degrading perception profile refuses a planner that reads the world's ground-truth maps and not the
/// believed world its observations carry.
fn refuse_map_reading(cfg: &EvalConfig, make: PlannerFactory<'_>) -> Result<(), EvalError> {
    if !cfg.perception.degrades_maps() {
        // No probe: a factory call is an episode's planner to callers that count them.
        return Ok(());
    }
    let probe = make();
    if !probe.runs_on_degraded_maps() {
        return Err(EvalError::Param {
            field: "perception".into(),
            message: format!(
                "planner {} reads the world's ground-truth maps, and profile {} degrades them: it runs under \
                 profiles that degrade only the state and the actuation",
                cfg.planner, cfg.perception.name
            ),
        });
    }
    Ok(())
}

/// One task's episode with a planner from `make`, under the run's perception profile, as its row (`None` once
/// the evaluation is cancelled).
fn run_task(
    cfg: &EvalConfig,
    set: &TaskSet,
    vehicle: &VehicleSpec,
    scale: f64,
    make: PlannerFactory<'_>,
    cancel: &AtomicBool,
    id: TaskId,
) -> Result<Option<EpisodeRow>, EvalError> {
    let (w, t) = (id.world, id.index);
    let world = set.world(w, scale)?;
    let task = set
        .tasks(w, scale)?
        .into_iter()
        .nth(t as usize)
        .ok_or(tasks::TasksError::UnknownWorld(w))?;
    let mut planner = make();
    let t0 = Instant::now();
    let mut hook = perception::hook(
        &cfg.perception,
        &world,
        id,
        task.start,
        cfg.episode.seed,
        vehicle.info().max_steer,
        1.0 / planner.control_rate_hz(),
    );
    let r = sim_core::run_episode_hooked(
        &world,
        &task,
        vehicle,
        planner.as_mut(),
        &cfg.episode,
        &mut CancelOnFlag(cancel),
        hook.as_mut(),
    );
    if cancel.load(Ordering::SeqCst) {
        return Ok(None);
    }
    Ok(Some(EpisodeRow {
        task_id: id,
        world_id: w,
        task_index: t,
        level: world.level,
        semantics: world.semantics,
        density: world.density,
        terrain: set.world_meta(w)?.terrain,
        planner: cfg.planner.clone(),
        vehicle: vehicle.name.as_str().into(),
        scale,
        seed: cfg.episode.seed,
        task_set_version: set.version().into(),
        sim_version: SIM_VERSION.into(),
        rules: cfg.episode.rules(),
        perception: cfg.perception.id(),
        outcome: RecordedOutcome::Episode(r.outcome),
        reason: r.reason,
        detail: r.detail,
        metrics: r.metrics,
        wall_time_s: t0.elapsed().as_secs_f64(),
    }))
}
