//! What the perception layer costs per call: one scan of the online map (the `nominal` and `degraded` sensors)
//! on rolling terrain, and one control step of the whole layer. `cargo bench -p perception`.

use contracts::TaskId;
use criterion::{criterion_group, criterion_main, Criterion};
use perception::map::{Mapper, Scan};
use perception::rng::{stream, Channel, EpisodeKey};
use perception::{Perception, Profile};
use sim_core::planner::VehicleState;
use sim_core::world::{Heightmap, Semantic, Surface, World};

fn world() -> World {
    World::uniform(
        Heightmap::from_fn(1.0, |x, y| 3.0 * (x / 11.0).sin() * (y / 7.0).cos()),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.6 },
    )
}

fn bench(c: &mut Criterion) {
    let w = world();
    let key = EpisodeKey {
        task: TaskId::new(1, 0),
        seed: 0,
        profile: 0,
    };
    for (name, range, k) in [
        ("30 m", 30.0, 1e-4),
        ("nominal", 20.0, 1e-4),
        ("degraded", 10.0, 2.5e-3),
    ] {
        let mut m = Mapper::new(&w, stream(&key, Channel::Elevation));
        let scan = Scan {
            origin: [0.0, 0.0, 5.0],
            heading: 0.0,
            range,
            fov: std::f64::consts::TAU,
            noise_k: k,
        };
        c.bench_function(&format!("scan {name} ({range} m)"), |b| {
            b.iter(|| m.scan(&w, &scan))
        });
    }
    let profile = Profile::builtin("nominal").unwrap();
    let mut p = Perception::new(&profile, &w, key.task, [0.0, 0.0], 0, 0.6, 0.1);
    let mut t = 0.0;
    c.bench_function("control step, nominal (a scan every other step)", |b| {
        b.iter(|| {
            t += 0.1;
            let truth = VehicleState {
                time: t,
                position: [(t % 50.0) - 25.0, 0.0, 1.0],
                ..Default::default()
            };
            p.observe(&w, &truth).state.position[0]
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
