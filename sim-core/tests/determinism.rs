//! Same inputs give bit-identical trajectories, run to run and at any thread count.

mod common;
use common::*;
use rayon::prelude::*;
use sim_core::episode::{EpisodeConfig, EpisodeResult};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Obstacle, ObstacleKind, Semantic, SoilParams, Surface, Task};

fn episode(k: usize) -> EpisodeResult {
    let t = 0.05 * k as f64;
    let mut w = world_with(
        move |x, y| 0.6 * (0.11 * x + t).sin() * (0.07 * y).cos(),
        Surface::Rigid { friction: 0.7 },
    );
    // Half the map is mud, so the soil's memory is exercised too.
    for (i, p) in w.patches.iter_mut().enumerate() {
        if i % 16 >= 8 {
            *p = sim_core::world::Patch {
                semantic: Semantic::Mud,
                surface: Surface::Deformable {
                    soil: SoilParams::MUD,
                },
            };
        }
    }
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: 0.0,
        y: 3.0,
        z: 0.0,
        yaw: 0.3,
        half_extents: [2.0, 2.0, 1.5],
    });
    let task = Task {
        world_id: 1,
        index: 0,
        start: [-40.0, -5.0],
        goal: [40.0, 5.0],
        path: vec![[-40.0, -5.0], [40.0, 5.0]],
    };
    let spec = vehicle_by_name(if k.is_multiple_of(2) { "hmmwv" } else { "m113" }).unwrap();
    let cfg = EpisodeConfig {
        record_hz: Some(50.0),
        max_time: 20.0,
        ..Default::default()
    };
    sim_core::run_episode(
        &w,
        &task,
        &spec,
        &mut sim_core::control::PurePursuit::new(),
        &cfg,
    )
}

fn bits(r: &EpisodeResult) -> Vec<u64> {
    r.trajectory
        .iter()
        .flat_map(|s| [s.x, s.y, s.z, s.roll, s.pitch, s.yaw, s.speed].map(f64::to_bits))
        .chain([
            r.metrics.energy.to_bits(),
            r.metrics.roll_abs.mean.to_bits(),
        ])
        .collect()
}

#[test]
fn trajectories_are_bit_identical_run_to_run_and_across_thread_counts() {
    let in_pool = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            (0..4)
                .into_par_iter()
                .map(|k| bits(&episode(k)))
                .collect::<Vec<_>>()
        })
    };
    let one = in_pool(1);
    let two = in_pool(2);
    let again = in_pool(2);
    assert!(
        one.iter().all(|b| b.len() > 100),
        "episodes recorded trajectories"
    );
    assert_eq!(one, two, "1 vs 2 threads");
    assert_eq!(two, again, "run to run");
}
