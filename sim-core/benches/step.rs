//! Criterion benches of the physics step: HMMWV driving on rigid ground, on mud, and the M113 on rigid ground.

use criterion::{criterion_group, criterion_main, Criterion};
use sim_core::planner::Action;
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::*;
use sim_core::Simulation;
use std::hint::black_box;

fn world(surface: Surface) -> World {
    let semantic = if matches!(surface, Surface::Rigid { .. }) {
        Semantic::Dirt
    } else {
        Semantic::Mud
    };
    let h = Heightmap::from_fn(1.0, |x, y| {
        0.8 * (0.13 * (x + 64.0)).sin() * (0.09 * (y + 64.0)).cos()
    });
    World {
        level: ElevationLevel::Medium,
        ..World::uniform(h, semantic, surface)
    }
}

fn bench(c: &mut Criterion) {
    let cases = [
        ("hmmwv_rigid", "hmmwv", Surface::Rigid { friction: 0.7 }),
        (
            "hmmwv_mud",
            "hmmwv",
            Surface::Deformable {
                soil: SoilParams::MUD,
            },
        ),
        ("m113_rigid", "m113", Surface::Rigid { friction: 0.7 }),
    ];
    let drive = Action {
        steering: 0.1,
        throttle: 0.3,
        brake: 0.0,
    };
    for (name, vehicle, surface) in cases {
        let w = world(surface);
        let spec = vehicle_by_name(vehicle).unwrap();
        // The settled start, copied back (without allocating) when the vehicle leaves the area, so the figure is
        // the step alone, not the settling of `Simulation::new` / `place`.
        let start = Simulation::new(&w, &spec, -50.0, 0.0, 0.0);
        let mut sim = start.clone();
        for _ in 0..500 {
            sim.step(&drive);
        }
        c.bench_function(&format!("step_{name}"), |b| {
            b.iter(|| {
                if sim.position().x > 50.0 || sim.position().y.abs() > 50.0 {
                    sim.set_dynamics(start.dynamics(), f64::INFINITY).unwrap();
                }
                black_box(sim.step(black_box(&drive)))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
