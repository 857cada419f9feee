//! `vb bench sim`: real-time factors of every vehicle on rigid and soft ground; `vb bench move-off`: the HMMWV's
//! move-off check beside the Chrono harness's on the same starts; `vb bench planner`, `vb bench
//! leaderboard` and `vb bench service` ([`super::bench_service`]): the service's costs.

use clap::Subcommand;
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum BenchCmd {
    /// Simulated seconds per wall-clock second, per vehicle, on a rigid and a deformable world (one core).
    Sim {
        /// Simulated seconds per run.
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        #[arg(long)]
        task_dir: Option<PathBuf>,
    },
    /// The HMMWV's move-off check (sim_core::move_off: settled at a task's start, full throttle towards the goal for
    /// 20 s) from every start of the chosen worlds, one after the other on one thread: wall time per start and
    /// simulated seconds per wall-clock second; with --reference, the Chrono harness's `move-off` of the same starts
    /// (`chrono-reference move-off --task-dir DIR --worlds IDS --out FILE`) beside it, and how many times faster.
    MoveOff {
        #[arg(long)]
        task_dir: Option<PathBuf>,
        /// World ids, comma-separated (default: the first rigid and the first deformable world, as `vb bench sim`).
        #[arg(long)]
        worlds: Option<String>,
        /// The harness's JSON for the same starts (its `move_off.wall_s` over its `move_off.tasks`).
        #[arg(long)]
        reference: Option<PathBuf>,
    },
    /// Round-trip overhead of a remote planner per control step (observation out, action back), through the worker's
    /// own code path: `vb bench planner -- PLANNER_COMMAND...` (it must serve on $VB_PLANNER_ADDR).
    Planner {
        /// Tasks to run (world ids and task ids).
        #[arg(long, default_value = "1,2,3")]
        tasks: String,
        #[arg(long)]
        task_dir: Option<PathBuf>,
        #[arg(last = true, required = true)]
        command: Vec<String>,
    },
    /// Latency of the leaderboard's pages and API at a fixed request rate on loopback, over a throw-away store seeded
    /// with finished submissions through the store's own API.
    Leaderboard(super::bench_leaderboard::Args),
    /// The service's overhead: a built-in planner's evaluation timed in-process (`vb eval`) and through the whole
    /// service (`vb serve --evaluate ... --exit-when-done`), one after the other, with the same results checked.
    Service {
        /// Built-in planner.
        #[arg(long, default_value = "pid")]
        planner: String,
        /// Tasks (as `vb eval --tasks`).
        #[arg(long, default_value = "all")]
        tasks: String,
        /// Threads of `vb eval` and worker slots of `vb serve` (default: the cores).
        #[arg(long, default_value_t = std::thread::available_parallelism().map_or(2, |n| n.get()))]
        slots: usize,
    },
}

/// The first rigid and the first deformable world of `set`.
pub(super) fn first_rigid_and_deformable(set: &tasks::TaskSet) -> anyhow::Result<(u32, u32)> {
    let pick = |kind: sim_core::world::SemanticsKind| -> anyhow::Result<u32> {
        set.world_ids()
            .into_iter()
            .find(|id| {
                set.world_meta(*id)
                    .map(|m| m.semantics == kind)
                    .unwrap_or(false)
            })
            .ok_or_else(|| anyhow::anyhow!("no {} world in the task set", kind.as_str()))
    };
    Ok((
        pick(sim_core::world::SemanticsKind::Rigid)?,
        pick(sim_core::world::SemanticsKind::Deformable)?,
    ))
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

fn bench_planner(tasks_spec: &str, task_dir: PathBuf, command: Vec<String>) -> anyhow::Result<()> {
    let set = std::sync::Arc::new(tasks::TaskSet::load(&task_dir)?);
    let selected = eval::run::select(&set, tasks_spec)?;
    let rt = tokio::runtime::Runtime::new()?;
    let mut trips = Vec::new();
    let (mut steps, mut remote_wall, mut local_wall) = (0usize, 0.0, 0.0);
    for (w, t) in &selected {
        let task_id = contracts::TaskId::new(*w, *t);
        let spec = vb_worker::EpisodeSpec {
            task_id,
            planner: vb_proto::v1::PlannerRef {
                kind: Some(vb_proto::v1::planner_ref::Kind::Exec(
                    vb_proto::v1::ExecPlanner {
                        argv: command.clone(),
                    },
                )),
            },
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            step_deadline_s: 1.0,
            max_time: None,
            containment: Default::default(),
            perception: vb_worker::perception::Profile::ideal(),
        };
        let cancel = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let run = rt
            .block_on(vb_worker::run_leased(
                set.clone(),
                spec,
                cancel,
                std::time::Duration::from_secs(30),
            ))
            .map_err(|e| anyhow::anyhow!(e))?;
        anyhow::ensure!(
            run.result.outcome != sim_core::episode::Outcome::PlannerFailure,
            "{task_id}: the planner failed: {}",
            run.result.detail
        );
        steps += run.round_trips.len();
        remote_wall += run.wall_time_s;
        trips.extend(run.round_trips);
        // The same episode with the built-in PID, in-process, for the cost of the simulation alone.
        let world = set.world(*w, 1.0)?;
        let task = set.tasks(*w, 1.0)?.remove(*t as usize);
        let vehicle = sim_core::vehicle::vehicle_by_name("hmmwv")?;
        let mut pid = baselines::by_name("pid").expect("pid");
        let t0 = std::time::Instant::now();
        sim_core::run_episode(&world, &task, &vehicle, pid.as_mut(), &Default::default());
        local_wall += t0.elapsed().as_secs_f64();
    }
    trips.sort_by(f64::total_cmp);
    let ms = |v: f64| v * 1e3;
    println!("episodes {}, control steps {steps}", selected.len());
    println!(
        "round trip per control step: p50 {:.3} ms, p90 {:.3} ms, p99 {:.3} ms, max {:.3} ms, mean {:.3} ms",
        ms(percentile(&trips, 0.5)),
        ms(percentile(&trips, 0.9)),
        ms(percentile(&trips, 0.99)),
        ms(trips.last().copied().unwrap_or(f64::NAN)),
        ms(trips.iter().sum::<f64>() / trips.len().max(1) as f64)
    );
    println!(
        "wall per episode: remote planner {:.3} s (incl. process start), in-process pid {:.3} s",
        remote_wall / selected.len() as f64,
        local_wall / selected.len() as f64
    );
    Ok(())
}

pub fn run(cmd: BenchCmd) -> anyhow::Result<()> {
    match cmd {
        BenchCmd::Service {
            planner,
            tasks,
            slots,
        } => super::bench_service::run(&planner, &tasks, slots.max(1)),
        BenchCmd::Leaderboard(a) => super::bench_leaderboard::run(a),
        BenchCmd::Planner {
            tasks,
            task_dir,
            command,
        } => bench_planner(
            &tasks,
            task_dir.unwrap_or_else(tasks::embedded::default_dir),
            command,
        ),
        BenchCmd::MoveOff {
            task_dir,
            worlds,
            reference,
        } => super::bench_move_off::run(
            &task_dir.unwrap_or_else(tasks::embedded::default_dir),
            worlds.as_deref(),
            reference.as_deref(),
        ),
        BenchCmd::Sim { seconds, task_dir } => bench_sim(seconds, task_dir),
    }
}

/// `vb bench sim`: steps per second of every vehicle on the first rigid and the first deformable world.
fn bench_sim(seconds: f64, task_dir: Option<std::path::PathBuf>) -> anyhow::Result<()> {
    anyhow::ensure!(
        seconds.is_finite() && seconds > 0.0,
        "--seconds must be positive"
    );
    let set = tasks::TaskSet::load(&task_dir.unwrap_or_else(tasks::embedded::default_dir))?;
    let (rigid, soft) = first_rigid_and_deformable(&set)?;
    println!("vehicle       ground      world  steps/s     us/step  real-time factor");
    for spec in sim_core::vehicle::builtin_vehicles() {
        for (label, id) in [("rigid", rigid), ("deformable", soft)] {
            let w = set.world(id, spec.scale)?;
            let t = &set.tasks(id, spec.scale)?[0];
            let cfg = sim_core::episode::EpisodeConfig {
                max_time: seconds,
                goal_radius: 0.0,
                stuck: sim_core::episode::StuckRule::Displacement {
                    distance: 0.0,
                    window: seconds + 1.0,
                },
                ..Default::default()
            };
            let mut p = sim_core::control::PurePursuit::new();
            let t0 = std::time::Instant::now();
            let r = sim_core::run_episode(&w, t, &spec, &mut p, &cfg);
            let wall = t0.elapsed().as_secs_f64();
            println!(
                "{:<13} {:<11} {:>5} {:>8.0} {:>11.2} {:>10.0}x   ({} after {:.1} s)",
                spec.name,
                label,
                id,
                r.metrics.steps as f64 / wall,
                wall * 1e6 / r.metrics.steps as f64,
                r.metrics.time / wall,
                r.outcome.as_str(),
                r.metrics.time
            );
        }
    }
    Ok(())
}
