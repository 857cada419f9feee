//! Golden trajectories: a hash of the bits of a few fixed runs is pinned next to [`sim_core::SIM_VERSION`], so a
//! change of trajectories without a revision bump fails here (and a bump without a new hash does too).
//!
//! To update after an intended physics change: bump the revision in `sim-core/src/lib.rs`, run this test, and copy
//! the printed hash into [`GOLDEN`] with the new version string.

mod common;
use common::*;
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Obstacle, ObstacleKind, Patch, Semantic, SoilParams, Surface};
use sim_core::Simulation;

/// The version whose trajectories [`GOLDEN`]'s hash pins.
const GOLDEN: (&str, u64) = ("sim-core 0.1.0 r10", 0xfb42_81bf_10c0_a49e);

/// FNV-1a over 64-bit words.
struct Fnv(u64);

impl Fnv {
    fn add(&mut self, v: f64) {
        for b in v.to_bits().to_le_bytes() {
            self.0 ^= u64::from(b);
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }
}

/// Rolling terrain, half of it mud and a quarter sand, a rock on the way.
fn world() -> sim_core::world::World {
    let mut w = world_with(
        |x, y| 0.8 * (0.13 * x).sin() * (0.09 * y).cos() + 0.02 * x,
        Surface::Rigid { friction: 0.7 },
    );
    for (i, p) in w.patches.iter_mut().enumerate() {
        let soil = match i % 16 {
            8..=11 => Some((Semantic::Mud, SoilParams::MUD)),
            12..=15 => Some((Semantic::Sand, SoilParams::SAND)),
            _ => None,
        };
        if let Some((semantic, soil)) = soil {
            *p = Patch {
                semantic,
                surface: Surface::Deformable { soil },
            };
        }
    }
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: 12.0,
        y: 2.0,
        z: 0.0,
        yaw: 0.4,
        half_extents: [1.0, 1.0, 0.8],
    });
    w
}

fn trajectory_hash(vehicle: &str, x0: f64, seconds: f64) -> u64 {
    let w = world();
    let spec = vehicle_by_name(vehicle).unwrap();
    let mut sim = Simulation::new(&w, &spec, x0, 0.0, 0.1);
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    let steps = (seconds / sim.dt()).round() as usize;
    for k in 0..steps {
        let t = k as f64 * sim.dt();
        let a = action(
            (0.3 + 0.2 * t).min(1.0),
            0.6 * (0.5 * t).sin(),
            if (6.0..7.0).contains(&t) { 0.8 } else { 0.0 },
        );
        sim.step(&a);
        let s = sim.state();
        for v in s
            .position
            .iter()
            .chain(&s.velocity)
            .chain(&s.angular_velocity)
        {
            h.add(*v);
        }
        for v in [s.roll, s.pitch, s.yaw] {
            h.add(v);
        }
        for v in sim.wheel_spins() {
            h.add(v);
        }
    }
    h.0
}

#[test]
fn trajectories_match_the_golden_hash_of_this_sim_version() {
    let mut all = Fnv(0xcbf2_9ce4_8422_2325);
    // Rigid to mud to sand (x from -20 to about 50), a tracked vehicle on soil, a 1/6-scale car, and a 1/10-scale
    // car on handling (Magic-Formula) tyres, which the other three do not use.
    for (vehicle, x0) in [
        ("hmmwv", -20.0),
        ("m113", 10.0),
        ("hmmwv_sixth", -4.0),
        ("artcar", -2.0),
    ] {
        let h = trajectory_hash(vehicle, x0, 12.0);
        eprintln!("{vehicle}: {h:#018x}");
        all.add(f64::from_bits(h));
    }
    eprintln!("golden hash for {}: {:#018x}", sim_core::SIM_VERSION, all.0);
    assert_eq!(
        sim_core::SIM_VERSION,
        GOLDEN.0,
        "SIM_VERSION changed: update GOLDEN to the new version and the hash printed above"
    );
    assert_eq!(
        all.0, GOLDEN.1,
        "trajectories changed under {}: bump the revision in sim-core/src/lib.rs and update GOLDEN",
        GOLDEN.0
    );
}
