//! The generators on a small training set (seed 7, worlds 1, 10 and 19: low relief, sparse obstacles, rigid,
//! deformable and mixed ground): determinism across thread counts, resume, the random protocol, failure windows,
//! expert filtering and the recorded observation (`generate_rules.rs`: the training-set rule and option checks).

use anyhow::Result;
use datasets::generate::failures::{failure_window, window_frames};
use datasets::generate::random::{drive_sinusoid, RandomStart, Sinusoid};
use datasets::generate::*;
use datasets::{DatasetKind, FailureClass, RecordedEpisode, Variant};
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::observe::{goal_vector, relative_elevation_crop, state_vector, CropSpec};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Heightmap, Semantic, Surface, World};
use sim_core::EpisodeRun;
use std::sync::Arc;
use tasks::TaskSet;

mod gen_support;
use gen_support::{config, training_set};

/// Period of a frame at 20 Hz for the HMMWV (13 physics steps of 4 ms).
const PERIOD: f64 = gen_support::PERIOD;

struct Out {
    main: Vec<RecordedEpisode>,
    failures: Vec<RecordedEpisode>,
    summary: GenerateSummary,
}

fn generate(cfg: &GenerateConfig, resume: &Resume, with_failures: bool) -> Result<Out> {
    let (mut main, mut failures) = (Vec::new(), Vec::new());
    let f: Option<&mut dyn EpisodeSink> = with_failures.then_some(&mut failures as _);
    let summary = run(cfg, resume, &mut main, f, &|_| {})?;
    Ok(Out {
        main,
        failures,
        summary,
    })
}

fn frames(recs: &[RecordedEpisode]) -> u64 {
    recs.iter().map(|r| r.frames.len() as u64).sum()
}

#[test]
fn random_is_the_same_at_any_thread_count_cut_at_the_hours_and_resumable() -> Result<()> {
    let mut cfg = config(DatasetKind::Random, 50.0 / 3600.0);
    cfg.variant = Variant::Full;
    cfg.crop_size = 8;
    cfg.threads = 1;
    let one = generate(&cfg, &Resume::default(), true)?;
    cfg.threads = 2;
    let two = generate(&cfg, &Resume::default(), true)?;
    assert!(one.main == two.main && one.failures == two.failures);
    assert_eq!(one.summary, two.summary);
    // Cut exactly at the first episode whose kept time reaches 50 s.
    let target = (50.0 / PERIOD).ceil() as u64;
    let n = one.main.len();
    assert!(n >= 2, "{n} episodes");
    assert!(frames(&one.main[..n - 1]) < target && frames(&one.main) >= target);
    assert_eq!(one.summary.kept_frames, frames(&one.main));
    assert!(one.summary.reached_hours);
    // Worlds take turns; every episode says how it ended; crops are there.
    for (i, r) in one.main.iter().enumerate() {
        assert_eq!(r.meta.world_id, [1, 10, 19][i % 3]);
        assert_eq!(r.meta.seed, episode_seed(11, i as u64));
        assert_eq!(r.meta.policy, "sinusoid");
        assert_eq!(
            r.frames.elevation.as_ref().map(Vec::len),
            Some(64 * r.frames.len())
        );
        let last = r.frames.len() - 1;
        assert!(r.frames.terminated[last] || r.frames.truncated[last]);
        assert_eq!(
            r.frames.truncated[last],
            r.meta.outcome == Outcome::Timeout,
            "{:?}",
            r.meta
        );
    }
    // Resume after episode 1 (main) and after every window of episodes up to 0 (failures): the tail of the run.
    let resume = Resume {
        main_next: 1,
        main_frames: frames(&one.main[..1]),
        failures_next: 0,
    };
    let rest = generate(&cfg, &resume, true)?;
    assert!(rest.main == one.main[1..] && rest.failures == one.failures);
    // The failures sink behind the main one: the main records again, the windows of episodes 2 and later.
    let resume = Resume {
        main_next: 0,
        main_frames: 0,
        failures_next: 2,
    };
    let again = generate(&cfg, &resume, true)?;
    let later: Vec<RecordedEpisode> = one
        .failures
        .iter()
        .filter(|w| {
            w.meta
                .failure
                .as_ref()
                .is_some_and(|f| f.source_episode >= 2)
        })
        .cloned()
        .collect();
    assert!(again.main == one.main && again.failures == later);
    let last = one.main.last().map(|r| &r.meta);
    let from = Resume::from_sinks(&cfg, last, frames(&one.main), None);
    assert_eq!(from.main_next, n as u64);
    let nothing = generate(&cfg, &from, false)?;
    assert!(nothing.main.is_empty() && nothing.summary.episodes_run == 0);
    Ok(())
}

#[test]
fn random_steering_follows_the_drawn_sinusoid() -> Result<()> {
    let out = generate(
        &config(DatasetKind::Random, 30.0 / 3600.0),
        &Resume::default(),
        false,
    )?;
    for r in &out.main {
        let p = &r.meta.policy_params;
        let (a, t, phi) = (p["amplitude"], p["period"], p["phase"]);
        assert!((0.2..1.0).contains(&a) && (2.0..10.0).contains(&t) && (0.0..6.3).contains(&phi));
        assert_eq!(p["speed"], 2.0);
        for (s, act) in r.frames.state.iter().zip(&r.frames.action) {
            let want = a * (std::f64::consts::TAU * s[14] / t + phi).sin();
            assert!((act[0] as f64 - want).abs() < 1e-4, "{} vs {want}", act[0]);
        }
    }
    Ok(())
}

#[test]
fn the_speed_loop_holds_2_mps_on_flat_rigid_ground() -> Result<()> {
    let flat = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    );
    let at = RandomStart {
        start: [-50.0, 0.0, 0.0],
        goal: [-50.0, 60.0],
        sinusoid: Sinusoid {
            amplitude: 0.3,
            period: 6.0,
            phase: 0.0,
            speed: 2.0,
        },
        stops: None,
    };
    let rules = EpisodeConfig {
        max_time: 40.0,
        ..EpisodeConfig::default()
    };
    let rec = drive_sinusoid(
        &Arc::new(flat),
        &vehicle_by_name("hmmwv")?,
        &at,
        &rules,
        20.0,
        None,
    );
    assert_eq!(rec.outcome, Outcome::Timeout);
    // After 10 s of speeding up: the forward speed stays within 0.05 m/s of 2 m/s, and averages within 0.02.
    let speeds: Vec<f64> = rec
        .frames
        .state
        .iter()
        .filter(|s| s[14] >= 10.0)
        .map(|s| s[12])
        .collect();
    let mean = speeds.iter().sum::<f64>() / speeds.len() as f64;
    let worst = speeds.iter().map(|v| (v - 2.0).abs()).fold(0.0, f64::max);
    eprintln!("speed after 10 s: mean {mean:.4} m/s, largest error {worst:.4} m/s");
    assert!(
        (mean - 2.0).abs() < 0.02 && worst < 0.05,
        "mean {mean}, worst {worst}"
    );
    Ok(())
}

#[test]
fn failure_windows_are_the_last_10_s_or_the_whole_short_episode() -> Result<()> {
    let mut cfg = config(DatasetKind::Random, 900.0 / 3600.0);
    cfg.max_time = 60.0;
    let out = generate(&cfg, &Resume::default(), true)?;
    let n = window_frames(PERIOD);
    assert_eq!(n, 192);
    assert!((n as f64 * PERIOD - 10.0).abs() <= PERIOD / 2.0);
    // Every rollover and stuck of the run gave a window, labelled as it ended.
    let failed: Vec<(usize, &RecordedEpisode)> = out
        .main
        .iter()
        .enumerate()
        .filter(|(_, r)| matches!(r.meta.outcome, Outcome::Rollover | Outcome::Stuck))
        .collect();
    assert!(!failed.is_empty() && failed.len() == out.failures.len());
    // And a long and a short synthetic one: a source episode cut to 300 and to 50 frames.
    let mut long = out.main[0].clone();
    long.meta.outcome = Outcome::Stuck;
    let mut short = long.clone();
    short.frames = failures::tail(&long.frames, 50);
    short.meta.outcome = Outcome::Rollover;
    let w = failure_window(&long, PERIOD, "random", 0).expect("a window");
    let len = long.frames.len();
    assert_eq!(w.frames.len(), n.min(len));
    assert_eq!(
        w.frames.state[..],
        long.frames.state[len - w.frames.len()..]
    );
    // The window ends where its source did: the same final observation.
    assert_eq!(
        (w.meta.final_state, w.meta.final_goal),
        (long.meta.final_state, long.meta.final_goal)
    );
    let f = w.meta.failure.as_ref().expect("labelled");
    assert!(
        f.class == FailureClass::Stuck
            && f.short == (len < n)
            && w.meta.kind == DatasetKind::Failures
    );
    let ws = failure_window(&short, PERIOD, "random", 0).expect("a window");
    let f = ws.meta.failure.as_ref().expect("labelled");
    assert!(
        ws.frames.len() == 50
            && f.short
            && f.start_time == 0.0
            && f.class == FailureClass::Rollover
    );
    for ((_, r), w) in failed.iter().zip(&out.failures) {
        let f = w.meta.failure.as_ref().expect("labelled");
        assert_eq!(w.frames.len(), n.min(r.frames.len()));
        assert_eq!(f.short, r.frames.len() < n);
        assert_eq!(f.source, "random");
        assert_eq!(
            w.frames.action[..],
            r.frames.action[r.frames.len() - w.frames.len()..]
        );
    }
    Ok(())
}

#[test]
fn expert_keeps_successes_and_drives_as_vb_eval() -> Result<()> {
    let cfg = config(DatasetKind::Expert, 600.0 / 3600.0);
    let out = generate(&cfg, &Resume::default(), true)?;
    assert!(!out.main.is_empty());
    assert!(out
        .main
        .iter()
        .all(|r| r.meta.outcome == Outcome::Success && r.meta.policy == "pid"));
    for w in &out.failures {
        let f = w.meta.failure.as_ref().expect("labelled");
        assert!(
            matches!(w.meta.outcome, Outcome::Rollover | Outcome::Stuck)
                && f.source == "expert:pid"
        );
    }
    assert!(!out.failures.is_empty());
    let ran: u64 = out.summary.outcomes.values().sum();
    assert_eq!(ran, out.summary.episodes_run);
    // The first demonstration ends as `vb eval`'s episode of its task, at the same step.
    let first = &out.main[0];
    let id = first.meta.task_id.expect("a task of the set");
    let set = TaskSet::load(training_set())?;
    let world = set.world(id.world, 1.0)?;
    let task = set.tasks(id.world, 1.0)?.remove(id.index as usize);
    let vehicle = vehicle_by_name("hmmwv")?;
    let mut pid = baselines::by_name("pid").expect("pid");
    let r = sim_core::run_episode(
        &world,
        &task,
        &vehicle,
        pid.as_mut(),
        &EpisodeConfig::default(),
    );
    assert_eq!(r.outcome, Outcome::Success);
    // The goal is reached during the last control period, at the same physics step.
    let n = first.frames.len() as u64;
    assert!((n - 1) * 13 < r.metrics.steps && r.metrics.steps <= n * 13);
    // Its frames are the observations the SDK computes, step by step.
    check_with_planner(first, &world, &task, &vehicle)
}

#[test]
fn expert_drawn_pairs_are_the_same_at_any_thread_count() -> Result<()> {
    // From episode 30 on (the set has 30 tasks), every episode drives a drawn pair.
    let mut cfg = config(DatasetKind::Expert, 120.0 / 3600.0);
    let resume = Resume {
        main_next: 30,
        main_frames: 0,
        failures_next: 30,
    };
    let two = generate(&cfg, &resume, true)?;
    cfg.threads = 1;
    let one = generate(&cfg, &resume, true)?;
    assert!(one.main == two.main && one.failures == two.failures && !one.main.is_empty());
    for r in &one.main {
        let i = episode_index(cfg.seed, r.meta.seed);
        assert!(
            i >= 30 && r.meta.task_id.is_none(),
            "episode {i}: {:?}",
            r.meta.task_id
        );
        assert_eq!(r.meta.world_id, [1, 10, 19][((i - 30) % 3) as usize]);
        assert!((r.meta.start[0].hypot(r.meta.start[1]) - 60.0).abs() < 1e-5);
    }
    assert_eq!(two.summary.next.main_next, two.summary.next.failures_next);
    Ok(())
}

#[test]
fn drawn_pairs_are_placed_as_the_generator_places_tasks() -> Result<()> {
    use rand::SeedableRng;
    let set = TaskSet::load(training_set())?;
    let rec = set.record(19)?;
    let blocked = tasks::path::occupancy(&rec.world, tasks::path::DEFAULT_INFLATION);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    for _ in 0..5 {
        let t = expert::draw_pair(&rec.world, &blocked, &mut rng).expect("a pair");
        assert!((t.start[0].hypot(t.start[1]) - 60.0).abs() < 1e-5);
        assert!((t.start[0] + t.goal[0]).abs() < 1e-9 && (t.start[1] + t.goal[1]).abs() < 1e-9);
        assert!(
            t.path.len() >= 2 && t.path[0] == t.start && *t.path.last().expect("goal") == t.goal
        );
    }
    Ok(())
}

#[test]
fn failures_scans_the_evaluation_runs() -> Result<()> {
    let mut cfg = config(DatasetKind::Failures, 1.0);
    cfg.planners = vec!["pid".into()];
    let out = generate(&cfg, &Resume::default(), false)?;
    assert_eq!(out.summary.episodes_run, 30);
    assert!(!out.summary.reached_hours);
    let failed = out.summary.outcomes.get("rollover").copied().unwrap_or(0)
        + out.summary.outcomes.get("stuck").copied().unwrap_or(0);
    assert_eq!(out.main.len() as u64, failed);
    for w in &out.main {
        let f = w.meta.failure.as_ref().expect("labelled");
        assert!(f.source == "eval:pid" && f.source_episode < 30 && w.meta.task_id.is_some());
        assert_eq!(w.frames.len(), 192.min(w.frames.len()));
    }
    Ok(())
}

/// Replays an expert episode with a fresh planner and compares every frame's state and goal with the SDK's.
fn check_with_planner(
    rec: &RecordedEpisode,
    world: &World,
    task: &sim_core::world::Task,
    vehicle: &sim_core::VehicleSpec,
) -> Result<()> {
    let mut run = EpisodeRun::new(world, task, vehicle, &EpisodeConfig::default());
    run.set_control_rate(20.0).map_err(anyhow::Error::msg)?;
    let mut pid = baselines::by_name("pid").expect("pid");
    let info = vehicle.info();
    pid.reset(&sim_core::planner::PlannerContext {
        world,
        task,
        vehicle: &info,
        spec: vehicle,
        sim_dt: run.dt(),
        believed: false,
    })?;
    let crop = CropSpec {
        size: 4,
        resolution: 1.0,
    };
    for k in 0..rec.frames.len() {
        let s = run.state();
        assert_eq!(state_vector(&s), sdk_state(&s));
        assert_eq!(goal_vector(&s, task.goal), sdk_goal(&s, task.goal));
        let (mut ours, mut sdk) = ([0f32; 16], [0f32; 16]);
        relative_elevation_crop(world, &s, &crop, &mut ours);
        sim_core::observe::elevation_crop(world, &s, &crop, &mut sdk);
        sdk.iter_mut().for_each(|h| *h -= s.position[2] as f32);
        assert_eq!(ours, sdk);
        // The SDK's float64 values, bit for bit (not rounded to float32).
        assert_eq!(
            rec.frames.state[k].map(f64::to_bits),
            sdk_state(&s).map(f64::to_bits),
            "frame {k}"
        );
        assert_eq!(
            rec.frames.goal[k].map(f64::to_bits),
            sdk_goal(&s, task.goal).map(f64::to_bits),
            "frame {k}"
        );
        let wheels: Vec<f32> = run
            .simulation()
            .wheels()
            .flat_map(|w| {
                [
                    w.sinkage as f32,
                    w.slip as f32,
                    w.normal_load as f32,
                    f32::from(u8::from(w.contact)),
                ]
            })
            .collect();
        assert_eq!(
            rec.frames.wheels[k * wheels.len()..(k + 1) * wheels.len()],
            wheels[..]
        );
        let a = pid.act(&run.observation())?;
        run.control(a).map_err(|e| anyhow::anyhow!("{e:?}"))?;
        let t = run.advance();
        assert_eq!(
            rec.frames.reward_terms[k],
            t.reward.as_array().map(|v| v as f32)
        );
        assert_eq!(rec.frames.terminated[k], t.terminated);
    }
    // The final observation: the state after the last frame's action.
    let s = run.state();
    assert_eq!(
        rec.meta.final_state.map(f64::to_bits),
        sdk_state(&s).map(f64::to_bits)
    );
    assert_eq!(
        rec.meta.final_goal.map(f64::to_bits),
        sdk_goal(&s, task.goal).map(f64::to_bits)
    );
    assert_ne!(rec.meta.final_state, rec.frames.state[rec.frames.len() - 1]);
    Ok(())
}

/// The Python SDK's state vector as `python/vertibench-py/src/obs.rs` wrote it before it called sim-core's.
fn sdk_state(s: &sim_core::planner::VehicleState) -> [f64; 15] {
    let [x, y, z] = s.position;
    let [vx, vy, vz] = s.velocity;
    let [wx, wy, wz] = s.angular_velocity;
    [
        x, y, z, s.roll, s.pitch, s.yaw, vx, vy, vz, wx, wy, wz, s.speed, s.steering, s.time,
    ]
}

fn sdk_goal(s: &sim_core::planner::VehicleState, goal: [f64; 2]) -> [f64; 3] {
    let (dx, dy) = (goal[0] - s.position[0], goal[1] - s.position[1]);
    let (sn, c) = s.yaw.sin_cos();
    [c * dx + sn * dy, -sn * dx + c * dy, dx.hypot(dy)]
}
