//! One run: what episode `i` is for each kind, and the loop that appends the episodes in index order and stops at
//! the first one whose kept time reaches the run's hours.

use super::expert::{drive_planner, expert_task, set_task, EpisodeTask};
use super::failures::{class_name, failure_window, source_name};
use super::plan::Plan;
use super::random::{draw, drive_sinusoid};
use super::recorder::{writable, Recorded};
use super::source::Source;
use super::stream::ordered;
use super::*;
use crate::record::{DatasetKind, EpisodeMeta, RecordedEpisode};
use contracts::{Outcome, TaskId};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sim_core::episode::EpisodeConfig;
use sim_core::runner::start_pose;
use sim_core::world::World;

/// What episode `i` gives: its record for the main sink, its failure window, and how it ended.
struct Output {
    main: Option<RecordedEpisode>,
    window: Option<RecordedEpisode>,
    outcome: Outcome,
    /// Frames the episode ran, kept or not.
    frames: u64,
}

/// Everything an episode reads.
struct Ctx<'a> {
    cfg: &'a GenerateConfig,
    src: Source,
    plan: Plan,
}

#[allow(clippy::too_many_arguments)]
fn record(
    kind: DatasetKind,
    world: &World,
    task_id: Option<TaskId>,
    start: [f64; 3],
    goal: [f64; 2],
    policy: &str,
    policy_params: std::collections::BTreeMap<String, f64>,
    seed: u64,
    rec: Recorded,
) -> RecordedEpisode {
    RecordedEpisode {
        meta: EpisodeMeta {
            kind,
            task_id,
            world_id: world.id,
            level: world.level,
            semantics: world.semantics,
            density: world.density,
            start_ground: world
                .patch_at(start[0], start[1])
                .semantic
                .as_str()
                .to_string(),
            start,
            goal,
            policy: policy.to_string(),
            policy_params,
            seed,
            outcome: rec.outcome,
            reason: rec.reason,
            failure: None,
            final_state: rec.final_state,
            final_goal: rec.final_goal,
        },
        frames: rec.frames,
    }
}

/// A planner's episode on `t` as a record of `kind`.
fn planner_record(
    ctx: &Ctx<'_>,
    kind: DatasetKind,
    t: &EpisodeTask,
    planner: &str,
    seed: u64,
) -> Result<RecordedEpisode, GenerateError> {
    let rec = drive_planner(&ctx.src, t, planner, ctx.plan.record_crop.as_ref())?;
    let (x, y, yaw) = start_pose(&t.task);
    let world = &ctx.src.worlds[t.world].world;
    Ok(record(
        kind,
        world,
        t.task_id,
        [x, y, yaw],
        t.task.goal,
        planner,
        Default::default(),
        seed,
        rec,
    ))
}

/// Episode `i` (see the module documentation of [`super`] and of each kind's module).
fn episode(ctx: &Ctx<'_>, i: u64) -> Result<Output, GenerateError> {
    let (cfg, src, period) = (ctx.cfg, &ctx.src, ctx.plan.period);
    let seed = episode_seed(cfg.seed, i);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    match cfg.kind {
        DatasetKind::Random => {
            let world = &src.worlds[(i % src.worlds.len() as u64) as usize].world;
            let at =
                draw(world, &src.vehicle.info(), cfg.speed_profile, &mut rng).ok_or_else(|| {
                    GenerateError::Episode {
                        index: i,
                        message: format!(
                            "world {}: no free start in {} draws",
                            world.id,
                            random::DRAWS
                        ),
                    }
                })?;
            let rules = EpisodeConfig {
                max_time: cfg.max_time,
                ..EpisodeConfig::default()
            };
            let crop = ctx.plan.record_crop.as_ref();
            let rec = drive_sinusoid(world, &src.vehicle, &at, &rules, cfg.control_rate_hz, crop);
            let params = at.params();
            let main = record(
                cfg.kind, world, None, at.start, at.goal, "sinusoid", params, seed, rec,
            );
            Ok(Output {
                outcome: main.meta.outcome,
                frames: main.frames.len() as u64,
                window: failure_window(&main, period, "random", i),
                main: Some(main),
            })
        }
        DatasetKind::Expert => {
            let planner = &cfg.planners[0];
            let t = expert_task(src, i, &mut rng)?;
            let rec = planner_record(ctx, cfg.kind, &t, planner, seed)?;
            let (outcome, frames) = (rec.meta.outcome, rec.frames.len() as u64);
            if outcome.is_success() {
                return Ok(Output {
                    main: Some(rec),
                    window: None,
                    outcome,
                    frames,
                });
            }
            Ok(Output {
                main: None,
                window: failure_window(&rec, period, &source_name(cfg.kind, planner), i),
                outcome,
                frames,
            })
        }
        DatasetKind::Failures => {
            let n = src.tasks.len() as u64;
            let planner = &cfg.planners[(i / n) as usize];
            let t = set_task(src, (i % n) as usize);
            let rec = planner_record(ctx, cfg.kind, &t, planner, seed)?;
            Ok(Output {
                outcome: rec.meta.outcome,
                frames: rec.frames.len() as u64,
                main: failure_window(&rec, period, &source_name(cfg.kind, planner), i % n),
                window: None,
            })
        }
    }
}

/// Runs (or resumes, after `resume`) the generation `cfg` asks for: episodes in index order into `sink` (and their
/// failure windows into `failures`, for random and expert runs), until the main sink holds `cfg.hours` of
/// simulated time (cut at the first episode that reaches it) or, for a failures run, its evaluation episodes are
/// done. `progress` hears about every episode index dealt with. The result is the same at any thread count, and a
/// resumed run appends exactly what the uninterrupted run would have appended after that point.
pub fn run(
    cfg: &GenerateConfig,
    resume: &Resume,
    sink: &mut dyn EpisodeSink,
    mut failures: Option<&mut dyn EpisodeSink>,
    progress: &dyn Fn(&GenerateProgress),
) -> Result<GenerateSummary, GenerateError> {
    if cfg.kind == DatasetKind::Failures && failures.is_some() {
        return Err(GenerateError::param(
            "failures",
            "a failures run writes its windows into the main sink; give no failures sink",
        ));
    }
    let (pool, ctx) = prepare(cfg)?;
    let target = ctx.plan.target_frames;
    let n_tasks = ctx.src.tasks.len() as u64;
    let end = (cfg.kind == DatasetKind::Failures).then(|| n_tasks * cfg.planners.len() as u64);
    let feeds_failures = failures.is_some();
    let first = if feeds_failures {
        resume.main_next.min(resume.failures_next)
    } else {
        resume.main_next
    };
    let mut kept_frames = resume.main_frames;
    // A main sink that already holds the hours ends at its last episode; the failures sink may still catch up.
    let mut cut = (kept_frames >= target).then(|| resume.main_next.saturating_sub(1));
    let mut s = GenerateSummary::resuming(resume);
    let give_up = n_tasks.max(100);
    let mut next_index = first;
    let mut simulated = 0u64;
    // The first index not to run: past the failures run's last episode, or past the cut.
    let limit = match (end, cut) {
        (Some(e), Some(c)) => Some(e.min(c + 1)),
        (e, c) => e.or(c.map(|c| c + 1)),
    };
    let mut consume = |i: u64, mut out: Output| -> Result<bool, GenerateError> {
        // A diverged simulation's frames cannot be written: the episode is dropped (and counted).
        for r in [&mut out.main, &mut out.window] {
            if r.as_ref().is_some_and(|r| !writable(r)) {
                *r = None;
                s.dropped += 1;
            }
        }
        s.episodes_run += 1;
        simulated += out.frames;
        *s.outcomes.entry(out.outcome.to_string()).or_default() += 1;
        if let (true, Some(rec)) = (i >= resume.main_next, &out.main) {
            sink.append(rec).map_err(|source| GenerateError::Sink {
                index: i,
                which: "main",
                source,
            })?;
            kept_frames += rec.frames.len() as u64;
            s.kept_episodes += 1;
            s.count_window(rec);
            if cut.is_none() && kept_frames >= target {
                cut = Some(i);
            }
        }
        if let (Some(f), true, Some(w)) =
            (failures.as_mut(), i >= resume.failures_next, &out.window)
        {
            f.append(w).map_err(|source| GenerateError::Sink {
                index: i,
                which: "failures",
                source,
            })?;
            s.failure_windows += 1;
            s.count_window(w);
        }
        next_index = i + 1;
        expert_succeeds(cfg, next_index, give_up, kept_frames)?;
        progress(&GenerateProgress {
            next_index,
            kept_frames,
            target_frames: target,
            kept_episodes: s.kept_episodes,
            failure_windows: s.failure_windows,
        });
        Ok(cut.is_none_or(|c| i < c))
    };
    let skip = limit.is_some_and(|l| first >= l);
    if !skip {
        let window = 2 * pool.current_num_threads() + 2;
        let job = |i: u64| episode(&ctx, i);
        ordered(&pool, first, limit, window, &job, &mut consume)?;
    }
    s.kept_frames = kept_frames;
    s.kept_seconds = kept_frames as f64 * ctx.plan.period;
    s.simulated_seconds = simulated as f64 * ctx.plan.period;
    s.reached_hours = kept_frames >= target;
    s.next = resume.after(next_index, kept_frames, feeds_failures);
    Ok(s)
}

/// An expert that never succeeds would run for ever: after `give_up` episodes without a kept frame, an error.
fn expert_succeeds(
    cfg: &GenerateConfig,
    next_index: u64,
    give_up: u64,
    kept_frames: u64,
) -> Result<(), GenerateError> {
    if cfg.kind == DatasetKind::Expert && next_index == give_up && kept_frames == 0 {
        return Err(GenerateError::param(
            "planners",
            format!(
                "planner `{}` succeeded in none of the first {give_up} episodes: no demonstrations to keep",
                cfg.planners[0]
            ),
        ));
    }
    Ok(())
}

/// The run's thread pool and what its episodes share: the configuration checked, the task source loaded (on the
/// pool) and the plan.
fn prepare(cfg: &GenerateConfig) -> Result<(rayon::ThreadPool, Ctx<'_>), GenerateError> {
    plan::check(cfg)?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cfg.threads)
        .build()
        .map_err(|e| GenerateError::Pool(e.to_string()))?;
    let src = pool.install(|| Source::load(cfg))?;
    let plan = Plan::new(cfg, &src.vehicle, src.scale)?;
    Ok((pool, Ctx { cfg, src, plan }))
}

impl GenerateSummary {
    /// Nothing run yet by this run, resuming after `resume`.
    fn resuming(resume: &Resume) -> GenerateSummary {
        GenerateSummary {
            episodes_run: 0,
            kept_episodes: 0,
            failure_windows: 0,
            kept_frames: resume.main_frames,
            kept_seconds: 0.0,
            simulated_seconds: 0.0,
            reached_hours: false,
            dropped: 0,
            next: *resume,
            outcomes: Default::default(),
            windows: Default::default(),
        }
    }

    /// Counts the failure window `rec` holds, if it holds one.
    fn count_window(&mut self, rec: &RecordedEpisode) {
        if let Some(fw) = &rec.meta.failure {
            *self
                .windows
                .entry(class_name(fw.class).to_string())
                .or_default() += 1;
        }
    }
}

impl Resume {
    /// Where a run that resumed at `self` stops: episodes dealt with up to `next_index`, `kept_frames` kept in the
    /// main sink, the failures sink fed too when `feeds_failures`.
    fn after(&self, next_index: u64, kept_frames: u64, feeds_failures: bool) -> Resume {
        Resume {
            main_next: next_index.max(self.main_next),
            main_frames: kept_frames,
            failures_next: if feeds_failures {
                next_index.max(self.failures_next)
            } else {
                self.failures_next
            },
        }
    }
}
