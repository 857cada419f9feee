//! Expert episodes: a built-in planner drives under the benchmark's rules (paper rules, 60 s), as `vb eval` runs
//! it; only its successes are demonstrations.
//!
//! Episode `i` of an expert run drives the task set's task `i` while there are any (in world, task order); after
//! them, world `(i - n) mod worlds` with a start/goal pair drawn the way the task generator draws its own
//! ([`draw_pair`]). The evaluation runs of a `failures` run drive the set's tasks only ([`drive_planner`]).

use super::recorder::{drive, Recorded};
use super::source::Source;
use super::GenerateError;
use contracts::TaskId;
use rand::Rng;
use sim_core::episode::EpisodeConfig;
use sim_core::observe::CropSpec;
use sim_core::world::{Task, World};
use sim_core::EpisodeRun;
use std::f64::consts::TAU;
use tasks::generate::TASK_RADIUS;
use tasks::obstacles::START_GOAL_CLEARANCE;
use tasks::path::plan_on_grid;

/// Tries for a drawn pair before falling back on one of the world's own tasks.
pub const PAIR_DRAWS: usize = 64;

/// A start/goal pair on a full-scale `world` as the task generator places its ten: diametrically opposite points
/// of the 60 m circle around the map's centre (rounded to the micrometre), here at a uniformly drawn angle instead
/// of the generator's 36 degree steps, kept only when no obstacle stands within the generator's start/goal
/// clearance (12 m) of either end and A* finds a path on `blocked` (obstacles inflated as for the set's paths).
/// Returns the full-scale task (index `u32::MAX`), or `None` after [`PAIR_DRAWS`] tries.
pub fn draw_pair(world: &World, blocked: &[bool], rng: &mut impl Rng) -> Option<Task> {
    let round = |v: f64| (v * 1e6).round() / 1e6 + 0.0;
    let clear = |p: [f64; 2]| {
        world
            .obstacles
            .iter()
            .all(|o| (p[0] - o.x).hypot(p[1] - o.y) >= START_GOAL_CLEARANCE)
    };
    (0..PAIR_DRAWS).find_map(|_| {
        let (s, c) = rng.gen_range(0.0..TAU).sin_cos();
        let start = [round(TASK_RADIUS * c), round(TASK_RADIUS * s)];
        let goal = [round(-TASK_RADIUS * c), round(-TASK_RADIUS * s)];
        if !(clear(start) && clear(goal)) {
            return None;
        }
        plan_on_grid(world, blocked, start, goal).map(|path| Task {
            world_id: world.id,
            index: u32::MAX,
            start,
            goal,
            path,
        })
    })
}

/// The task of an episode: its world (position in the source's worlds), the task at the run's scale, and its id
/// when it is one of the set's tasks.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeTask {
    pub world: usize,
    pub task: Task,
    pub task_id: Option<TaskId>,
}

/// Task `k` of the set.
pub fn set_task(src: &Source, k: usize) -> EpisodeTask {
    let (w, t) = src.tasks[k];
    let task = src.worlds[w].tasks[t].clone();
    EpisodeTask {
        world: w,
        task_id: Some(TaskId::new(task.world_id, task.index)),
        task,
    }
}

/// The task of expert episode `index` (see the module documentation). When no pair can be drawn on the world
/// (obstacles everywhere), the episode drives one of the world's own tasks, with its id.
pub fn expert_task(
    src: &Source,
    index: u64,
    rng: &mut impl Rng,
) -> Result<EpisodeTask, GenerateError> {
    let n = src.tasks.len() as u64;
    if index < n {
        return Ok(set_task(src, index as usize));
    }
    let k = index - n;
    let nw = src.worlds.len() as u64;
    let w = (k % nw) as usize;
    let lw = &src.worlds[w];
    if let Some(t) = draw_pair(&lw.full, &lw.blocked, rng) {
        return Ok(EpisodeTask {
            world: w,
            task: t.scaled(src.scale),
            task_id: None,
        });
    }
    let own = lw.tasks.len() as u64;
    let t = (own > 0)
        .then(|| lw.tasks[((k / nw) % own.max(1)) as usize].clone())
        .ok_or_else(|| GenerateError::Episode {
            index,
            message: format!(
                "world {}: no start/goal pair could be drawn and it has no tasks",
                lw.full.id
            ),
        })?;
    Ok(EpisodeTask {
        world: w,
        task_id: Some(TaskId::new(t.world_id, t.index)),
        task: t,
    })
}

/// Drives `task` with the built-in planner `planner` under the benchmark's rules, recording crops when `crop` is
/// given.
pub fn drive_planner(
    src: &Source,
    task: &EpisodeTask,
    planner: &str,
    crop: Option<&CropSpec>,
) -> Result<Recorded, GenerateError> {
    let mut p = baselines::by_name(planner)
        .ok_or_else(|| GenerateError::param("planners", format!("unknown planner `{planner}`")))?;
    let world = &src.worlds[task.world].world;
    let rules = EpisodeConfig::default();
    let run = EpisodeRun::new_shared(world.clone(), &task.task, &src.vehicle, &rules);
    Ok(drive(
        run,
        p.as_mut(),
        world,
        &task.task,
        crop,
        rules.max_time,
    ))
}
