//! The soil at speed, where the SCM's damping pressure `-R (v . N)` lifts a wheel out of soft soil (the driven rig's
//! HMMWV wheel on snow rides 30 cm deep at 1 m/s, 7 cm at 10 m/s): its force and moment on a rolling rim against the
//! arc integral, and the single-wheel rig converged in the time step at speed (issue 13, point 3).

use nalgebra::Vector3;
use sim_core::soil::rig::{Drive, WheelRig};
use sim_core::soil::{SoilGrid, WheelGeometry};
use sim_core::world::*;

const R: f64 = 0.467;
const B: f64 = 0.254;

/// The soil's vertical force, horizontal force and moment about the axle at one position, N and N m.
type Sample = (f64, f64, f64);

/// A wheel rolling at `v` and constant height, its rim `z` below the surface, over soil that has only the SCM's
/// damping (Bekker moduli of 1 Pa/m, no shear strength): the soil's vertical force on it and its moment about the
/// axle. Chrono's damping pressure `-R (v . N)`, `v` the rim's material velocity (the spin included), `N` the
/// terrain's normal (SCMTerrain.cpp: `Vn = v . N`, `sigma += -Vn R`, force along `N` over the cell's horizontal
/// area): for a rim rolling without slip at constant height `R omega u` at `u` ahead of the axle on the front arc
/// `0 <= u <= u_f = r sin(theta1)`, `theta1 = acos(1 - z / r)`. Integrated over the arc: `F_z = R omega b u_f^2 / 2`
/// and the moment about the axle `-R omega b u_f^3 / 3` (against the spin); no horizontal force.
fn damping_only(v: f64, z: f64) -> (Vec<Sample>, (f64, f64)) {
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
    let mut grid = SoilGrid::new(world);
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
            forces.push((c.force.z, c.force.x, c.torque.y));
        }
    }
    let u_f = R * (1.0 - z / R).acos().sin();
    let r_omega_b = soil.damping * v / R * B;
    let theory = (r_omega_b * u_f * u_f / 2.0, -r_omega_b * u_f.powi(3) / 3.0);
    (forces, theory)
}

#[test]
fn a_rolling_rim_s_damping_force_is_the_arc_integral_at_every_position() {
    // On the benchmark's 0.1 m grid a 5 cm deep front arc is 0.21 m long, two nodes. The damped area grows
    // continuously as the rim's edge advances over a cell and the bottom's cell is damped on its front part only
    // (`RimPoint::damping`), so the force does not jump as nodes enter: F_z at every position (1 cm apart over 2 m)
    // within 6% of the arc integral, its mean within 3%; the moment's mean within 8% (the midpoint rule on the
    // cubic integrand); the horizontal force zero to rounding (the pressure acts along the terrain's normal).
    // (sim-core r5, whole cells switching on as their rays were pressed: F_z -37% to +49% over positions at 10 m/s.)
    for (v, z) in [(10.0, 0.05), (25.0, 0.03)] {
        let (forces, (fz, my)) = damping_only(v, z);
        let n = forces.len() as f64;
        let mean_z = forces.iter().map(|f| f.0).sum::<f64>() / n;
        let max_x = forces.iter().map(|f| f.1.abs()).fold(0.0, f64::max);
        let mean_m = forces.iter().map(|f| f.2).sum::<f64>() / n;
        let (lo, hi) = forces.iter().fold((f64::MAX, f64::MIN), |(lo, hi), f| {
            (lo.min(f.0 / fz - 1.0), hi.max(f.0 / fz - 1.0))
        });
        eprintln!(
            "v {v} m/s, rim {z} m deep: F_z {mean_z:.0} N (arc integral {fz:.0}, {:+.1}% .. {:+.1}% over positions), moment {mean_m:.0} N m (arc integral {my:.0}), |F_x| <= {max_x:.1e} N",
            lo * 100.0,
            hi * 100.0
        );
        assert!((mean_z / fz - 1.0).abs() < 0.03, "F_z {mean_z} vs {fz}");
        assert!((mean_m / my - 1.0).abs() < 0.08, "moment {mean_m} vs {my}");
        assert!(max_x < 1e-9 * fz, "horizontal force {max_x}");
        assert!(lo > -0.06 && hi < 0.06, "F_z over positions {lo} .. {hi}");
    }
}

#[test]
fn the_rig_at_speed_gives_the_same_sinkage_and_pull_at_4_ms_and_1_ms() {
    // The HMMWV wheel on snow at 10 and 20 m/s, towed and driven at 20% slip: 4 ms against 1 ms within 5% (sinkage;
    // 12% towed) and 15% or 0.01 W (pull: it is the difference of traction and resistance). A towed wheel spins
    // where the soil's moment about its axle vanishes, which depends on where on the arc the slip changes sign, and
    // the step samples that point: the towed slip is -0.14 at 4 ms, -0.07 at 1 ms (10 m/s), and the spin sets the
    // damping pressure `R omega u` that carries the wheel, so its sinkage differs by 7% (10 m/s) and 10% (20 m/s). The Janosi shear displacement of a
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
            let sinkage_tolerance = if drive == Drive::Towed { 0.12 } else { 0.05 };
            assert!(
                (a.sinkage / b.sinkage - 1.0).abs() < sinkage_tolerance,
                "{a:?} vs {b:?}"
            );
            let dp = (a.drawbar_pull - b.drawbar_pull).abs();
            assert!(
                dp < (0.15 * b.drawbar_pull.abs()).max(0.01 * w),
                "{a:?} vs {b:?}"
            );
        }
    }
}
