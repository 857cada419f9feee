//! Criterion benches of the Soil Contact Model: one HMMWV-sized wheel (r 0.47 m, b 0.32 m, 12 kN) rolling on mud
//! and sand with 20% slip, a four-wheel step, and a track shoe. Reports time per call; nodes per call are printed
//! once so the cost per node can be read off.

use criterion::{criterion_group, criterion_main, Criterion};
use nalgebra::Vector3;
use sim_core::soil::{PlateGeometry, SoilGrid, WheelGeometry};
use sim_core::world::*;
use std::hint::black_box;

fn grid(soil: SoilParams) -> SoilGrid {
    SoilGrid::new(World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Mud,
        Surface::Deformable { soil },
    ))
}

fn wheel(x: f64, y: f64, z: f64) -> WheelGeometry {
    let (r, v) = (0.47, 5.0);
    WheelGeometry {
        centre: Vector3::new(x, y, z),
        axle: Vector3::y(),
        radius: r,
        width: 0.32,
        velocity: Vector3::new(v, 0.0, 0.0),
        angular_velocity: Vector3::new(0.0, v / (r * 0.8), 0.0),
    }
}

fn bench(c: &mut Criterion) {
    let dt = 0.004;
    for (name, soil, depth) in [
        ("mud", SoilParams::MUD, 0.05),
        ("sand", SoilParams::SAND, 0.02),
    ] {
        let mut g = grid(soil);
        let z = 0.47 - depth;
        g.begin_step();
        let nodes = g.wheel_contact(&wheel(0.0, 0.0, z), dt).nodes;
        eprintln!("{name}: {nodes} nodes per wheel call");
        let mut x = -50.0;
        c.bench_function(&format!("soil_wheel_{name}"), |b| {
            b.iter(|| {
                // Rolls forward 2 cm a call over fresh and rutted soil, wrapping before the map's edge.
                x = if x > 50.0 { -50.0 } else { x + 0.02 };
                g.begin_step();
                black_box(g.wheel_contact(black_box(&wheel(x, 0.0, z)), dt))
            })
        });
        let mut x = -50.0;
        c.bench_function(&format!("soil_four_wheels_{name}"), |b| {
            b.iter(|| {
                x = if x > 50.0 { -50.0 } else { x + 0.02 };
                g.begin_step();
                for (dx, dy) in [(1.7, 0.9), (1.7, -0.9), (-1.6, 0.9), (-1.6, -0.9)] {
                    black_box(g.wheel_contact(black_box(&wheel(x + dx, dy, z)), dt));
                }
            })
        });
    }
    let mut g = grid(SoilParams::MUD);
    let mut x = -50.0;
    c.bench_function("soil_track_shoe_mud", |b| {
        b.iter(|| {
            x = if x > 50.0 { -50.0 } else { x + 0.02 };
            g.begin_step();
            let shoe = PlateGeometry {
                centre: Vector3::new(x, 0.0, -0.04),
                forward: Vector3::x(),
                up: Vector3::z(),
                length: 0.15,
                width: 0.38,
                velocity: Vector3::new(0.5, 0.0, 0.0),
                angular_velocity: Vector3::zeros(),
            };
            black_box(g.plate_contact(black_box(&shoe), dt))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
