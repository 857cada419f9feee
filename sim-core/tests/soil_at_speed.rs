//! The soil at speed, where the SCM's damping pressure `R |v . N|` lifts a wheel out of soft soil (the towed rig's
//! HMMWV wheel on snow rides 34 cm deep at 0.25 m/s, 8 cm at 10 m/s): its force on a rolling rim against the arc
//! integral, and the single-wheel rig converged in the time step at speed (issue 13, point 3).

use nalgebra::Vector3;
use sim_core::soil::rig::{Drive, WheelRig};
use sim_core::soil::{SoilGrid, WheelGeometry};
use sim_core::world::*;

const R: f64 = 0.467;
const B: f64 = 0.254;

/// A wheel rolling at `v` and constant height, its rim `z` below the surface, over soil that has only the SCM's
/// damping (Bekker moduli of 1 Pa/m, no shear strength): the soil's vertical and longitudinal force on it. The
/// damping pressure `R v sin(theta)` on the front arc, `0 <= theta <= theta1 = acos(1 - z / r)`, integrated over
/// the arc (Chrono's SCM damping term, physics.md section 2.4; the arc integral as in Wong, Theory of Ground
/// Vehicles, section 2.6, for the normal stress of a rigid wheel): `F_z = R v b r sin^2(theta1) / 2`,
/// `F_x = -R v b r (theta1 / 2 - sin(2 theta1) / 4)`.
fn damping_only(v: f64, z: f64) -> (Vec<(f64, f64)>, (f64, f64)) {
    let soil = SoilParams {
        k_phi: 1.0,
        k_c: 0.0,
        n: 1.0,
        cohesion: 0.0,
        friction_angle_deg: 0.0,
        janosi_k: 0.01,
        elastic_k: 4e7,
        damping: 3e4,
    };
    let world = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Snow,
        Surface::Deformable { soil },
    );
    let mut grid = SoilGrid::new(&world);
    let dt = 1e-3;
    let mut forces = Vec::new();
    for k in 0..(2.5 / (v * dt)) as usize {
        grid.begin_step();
        let x = -1.0 + v * dt * k as f64;
        let c = grid.wheel_contact(
            &WheelGeometry {
                centre: Vector3::new(x, 0.037, R - z),
                axle: Vector3::y(),
                radius: R,
                width: B,
                velocity: Vector3::new(v, 0.0, 0.0),
                angular_velocity: Vector3::new(0.0, v / R, 0.0),
            },
            dt,
        );
        if x > -0.5 {
            forces.push((c.force.z, c.force.x));
        }
    }
    let t1 = (1.0 - z / R).acos();
    let rvbr = soil.damping * v * B * R;
    let theory = (
        rvbr * t1.sin().powi(2) / 2.0,
        -rvbr * (t1 / 2.0 - (2.0 * t1).sin() / 4.0),
    );
    (forces, theory)
}

#[test]
fn a_rolling_rim_s_damping_force_is_the_arc_integral_at_every_position() {
    // On the benchmark's 0.1 m grid a 5 cm deep front arc is 0.21 m long, two nodes. The damped area grows
    // continuously as the rim's edge advances over a cell and the bottom's cell is damped on its front part only
    // (`RimPoint::damping`), so the force does not jump as nodes enter: F_z at every position (1 cm apart over 2 m)
    // within 6% of the arc integral, its mean within 3%; F_x's mean within 8% (the midpoint rule on the arc's convex
    // horizontal integrand gives -5 to -7%). (sim-core r5, whole cells switching on as their rays were pressed:
    // F_z -37% to +49% over positions at 10 m/s.)
    for (v, z) in [(10.0, 0.05), (25.0, 0.03)] {
        let (forces, (fz, fx)) = damping_only(v, z);
        let n = forces.len() as f64;
        let mean_z = forces.iter().map(|f| f.0).sum::<f64>() / n;
        let mean_x = forces.iter().map(|f| f.1).sum::<f64>() / n;
        let (lo, hi) = forces.iter().fold((f64::MAX, f64::MIN), |(lo, hi), f| {
            (lo.min(f.0 / fz - 1.0), hi.max(f.0 / fz - 1.0))
        });
        eprintln!(
            "v {v} m/s, rim {z} m deep: F_z {mean_z:.0} N (arc integral {fz:.0}, {:+.1}% .. {:+.1}% over positions), F_x {mean_x:.0} N (arc integral {fx:.0})",
            lo * 100.0,
            hi * 100.0
        );
        assert!((mean_z / fz - 1.0).abs() < 0.03, "F_z {mean_z} vs {fz}");
        assert!((mean_x / fx - 1.0).abs() < 0.08, "F_x {mean_x} vs {fx}");
        assert!(lo > -0.06 && hi < 0.06, "F_z over positions {lo} .. {hi}");
    }
}

#[test]
fn the_rig_at_speed_gives_the_same_sinkage_and_pull_at_4_ms_and_1_ms() {
    // The HMMWV wheel on snow at 10 and 20 m/s, towed and driven at 20% slip: 4 ms against 1 ms within 5% (sinkage)
    // and 15% or 0.01 W (pull: it is the difference of traction and resistance). The Janosi shear displacement of a
    // node accrues from when the rim reaches it, not from the start of that step (sim-core r5's driven pull at
    // 20 m/s: 0.216 W at 4 ms, 0.150 W at 1 ms).
    let w = 2493.6 * 9.81 / 4.0;
    for speed in [10.0, 20.0] {
        for drive in [Drive::Towed, Drive::Slip(0.2)] {
            let run = |dt: f64| {
                let mut rig = WheelRig::new(SoilParams::SNOW, R, B, w);
                rig.speed = speed;
                rig.dt = dt;
                rig.distance = 12.0;
                rig.window = 6.0;
                rig.run(drive)
            };
            let (a, b) = (run(4e-3), run(1e-3));
            eprintln!(
                "{speed} m/s {drive:?}: sinkage {:.4} / {:.4} m, pull {:.3} / {:.3} W (4 ms / 1 ms)",
                a.sinkage,
                b.sinkage,
                a.drawbar_pull / w,
                b.drawbar_pull / w
            );
            assert!((a.sinkage / b.sinkage - 1.0).abs() < 0.05, "{a:?} vs {b:?}");
            let dp = (a.drawbar_pull - b.drawbar_pull).abs();
            assert!(
                dp < (0.15 * b.drawbar_pull.abs()).max(0.01 * w),
                "{a:?} vs {b:?}"
            );
        }
    }
}
