//! Physics validation against analytic results. Each test states its tolerance.

mod common;
use common::*;
use nalgebra::Vector3;
use sim_core::vehicle::spec::Differential;
use sim_core::vehicle::{vehicle_by_name, VehicleSpec};
use sim_core::world::{Obstacle, ObstacleKind, Surface};
use sim_core::Simulation;

fn hmmwv() -> VehicleSpec {
    vehicle_by_name("hmmwv").unwrap()
}

#[test]
fn brakes_hold_below_atan_mu_and_slide_above() {
    // mu = min(tyre 0.9, ground 0.6) = 0.6, atan(0.6) = 31 degrees. Hold: < 5 cm in 5 s at 26 degrees;
    // slide: > 1 m in 5 s at 36 degrees.
    for (deg, holds) in [(26.0, true), (36.0, false)] {
        let w = slope_x(deg, 0.6);
        let mut sim = Simulation::new(&w, &hmmwv(), 0.0, 0.0, 0.0);
        run(&mut sim, 1.0, action(0.0, 0.0, 1.0));
        let p0 = sim.position();
        run(&mut sim, 5.0, action(0.0, 0.0, 1.0));
        let moved = (sim.position() - p0).norm();
        if holds {
            assert!(moved < 0.05, "{deg} deg: slid {moved} m with brakes on");
        } else {
            assert!(moved > 1.0, "{deg} deg: held ({moved} m) above atan(mu)");
        }
    }
}

#[test]
fn static_sag_is_load_over_stiffness() {
    // Two-axle HMMWV at rest: spring force = axle load / 2 - unsprung weight, sag = force / k; within 3%.
    let spec = hmmwv();
    let w = flat(0.8);
    let mut sim = Simulation::new(&w, &spec, 0.0, 0.0, 0.0);
    run(&mut sim, 4.0, action(0.0, 0.0, 1.0));
    let comp: Vec<f64> = sim.compressions().collect();
    let (a, b) = (spec.axles[0].x, spec.axles[1].x);
    let m = spec.chassis.mass;
    let unsprung = 0.04 * m * 9.81;
    let front = (m * 9.81 * (-b) / (a - b) / 2.0 - unsprung) / spec.axles[0].spring;
    let rear = (m * 9.81 * a / (a - b) / 2.0 - unsprung) / spec.axles[1].spring;
    for (got, want) in [
        (comp[0], front),
        (comp[1], front),
        (comp[2], rear),
        (comp[3], rear),
    ] {
        assert!(
            (got - want).abs() <= 0.03 * want,
            "sag {got:.5} m vs load/k {want:.5} m"
        );
    }
}

#[test]
fn low_speed_turning_radius_matches_ackermann_geometry() {
    // Open differentials (free wheels): R = wheelbase / tan(delta) within 5% at 2 m/s.
    let mut spec = hmmwv();
    spec.powertrain.differential = Differential::Open;
    let w = flat(0.8);
    let mut sim = Simulation::new(&w, &spec, -40.0, 0.0, 0.0);
    let steer = 0.5;
    for _ in 0..(30.0 / sim.dt()) as usize {
        let v = sim.state().speed;
        sim.step(&action(if v < 2.0 { 0.15 } else { 0.0 }, steer, 0.0));
    }
    let s = sim.state();
    let radius = s.speed / s.angular_velocity[2];
    let want = spec.wheelbase() / (steer * spec.steering.max_angle).tan();
    assert!(
        (radius - want).abs() <= 0.05 * want,
        "turning radius {radius:.2} m vs {want:.2} m"
    );
}

#[test]
fn all_wheel_drive_climbs_below_atan_mu_and_not_above() {
    // mu = 0.6: atan = 31 degrees. Climbs 26 degrees (> 8 m uphill in 15 s), cannot climb 36 degrees (< 1 m).
    for (deg, climbs) in [(26.0, true), (36.0, false)] {
        let w = slope_x(deg, 0.6);
        let mut sim = Simulation::new(&w, &hmmwv(), -20.0, 0.0, 0.0);
        run(&mut sim, 0.5, action(0.0, 0.0, 1.0));
        let x0 = sim.position().x;
        run(&mut sim, 15.0, action(1.0, 0.0, 0.0));
        let gain = sim.position().x - x0;
        if climbs {
            assert!(gain > 8.0, "{deg} deg: only {gain:.2} m uphill");
        } else {
            assert!(gain < 1.0, "{deg} deg: climbed {gain:.2} m above atan(mu)");
        }
    }
}

#[test]
fn static_rollover_on_a_side_slope_near_the_stability_limit() {
    // Tilt-table limit atan(track / (2 h_cg)) (Gillespie, Fundamentals of Vehicle Dynamics, eq. 9-3, rigid
    // vehicle); HMMWV: atan(1.82 / 1.226) = 56.0 degrees with its CoG 0.613 m above the ground (the suspension
    // lowers it a few degrees). With grippy tyres it stands 8 degrees below the limit
    // and tips over 8 degrees above it.
    let mut spec = hmmwv();
    spec.wheels.mu = 3.0;
    let limit = (spec.track() / (2.0 * (spec.chassis.com_height + spec.wheels.radius)))
        .atan()
        .to_degrees();
    assert!((limit - 56.0).abs() < 1.0, "{limit}");
    for (deg, stands) in [(limit - 8.0, true), (limit + 8.0, false)] {
        let w = slope_y(deg, 3.0);
        let mut sim = Simulation::new(&w, &spec, 0.0, 0.0, 0.0);
        // The largest roll over 4 s with brakes on (a vehicle that tips tumbles down the slope afterwards).
        let mut roll: f64 = 0.0;
        for _ in 0..(4.0 / sim.dt()).round() as usize {
            sim.step(&action(0.0, 0.0, 1.0));
            roll = roll.max(sim.state().roll.to_degrees().abs());
        }
        if stands {
            assert!(
                (roll - deg).abs() < 6.0,
                "{deg:.1} deg: roll {roll:.1}, should stand on the slope"
            );
        } else {
            // Tipped: rotated more than 10 degrees beyond the slope, its uphill wheels in the air.
            assert!(
                roll > deg + 10.0,
                "{deg:.1} deg: roll {roll:.1}, should tip over"
            );
        }
    }
}

#[test]
fn a_tracked_vehicle_turns_in_place() {
    // Full steering, no throttle: > 90 degrees of yaw in 10 s while the centre moves < 2 m.
    let spec = vehicle_by_name("m113").unwrap();
    let w = flat(0.8);
    let mut sim = Simulation::new(&w, &spec, 0.0, 0.0, 0.0);
    let mut yaw_total = 0.0;
    let mut last = sim.state().yaw;
    for _ in 0..(10.0 / sim.dt()) as usize {
        sim.step(&action(0.0, 1.0, 0.0));
        let y = sim.state().yaw;
        let d = (y - last).sin().atan2((y - last).cos());
        yaw_total += d;
        last = y;
    }
    let p = sim.position();
    assert!(
        yaw_total > 90f64.to_radians(),
        "yawed {:.1} deg",
        yaw_total.to_degrees()
    );
    assert!(p.x.hypot(p.y) < 2.0, "centre moved {:.2} m", p.x.hypot(p.y));
}

#[test]
fn collisions_at_top_speed_stop_the_vehicle_without_tunnelling() {
    // A rock and a tree (the thinnest obstacle) hit at the HMMWV's top speed: the chassis never passes the
    // obstacle's centre plane and ends up slower than 20% of the impact speed.
    let spec = hmmwv();
    for kind in [ObstacleKind::Rock, ObstacleKind::Tree] {
        let mut w = flat(0.8);
        let half = if kind == ObstacleKind::Rock {
            [2.0, 2.0, 1.9]
        } else {
            [0.5, 0.5, 2.5]
        };
        w.obstacles.push(Obstacle {
            kind,
            x: 0.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
            half_extents: half,
        });
        let mut sim = Simulation::new(&w, &spec, -20.0, 0.0, 0.0);
        run(&mut sim, 0.5, action(0.0, 0.0, 0.0));
        sim.set_velocity(Vector3::new(spec.max_speed, 0.0, 0.0));
        let mut max_x = f64::NEG_INFINITY;
        for _ in 0..(2.0 / sim.dt()) as usize {
            sim.step(&action(0.0, 0.0, 0.0));
            max_x = max_x.max(sim.position().x);
        }
        let front = max_x + spec.chassis.size[0] / 2.0;
        assert!(
            front < 0.0,
            "{kind:?}: the front reached x = {front:.2} m, past the obstacle's centre"
        );
        assert!(
            sim.velocity().x < 0.2 * spec.max_speed,
            "{kind:?}: still at {:.1} m/s",
            sim.velocity().x
        );
    }
}

#[test]
fn a_coast_on_a_frictionless_plane_gains_no_energy() {
    // Kinetic energy of a vehicle launched at 10 m/s with a yaw rate on ice (mu = 0): it may only lose energy
    // (suspension damping); tolerance 0.5% growth.
    let w = world_with(|_, _| 0.0, Surface::Rigid { friction: 0.0 });
    let mut sim = Simulation::new(&w, &hmmwv(), -40.0, 0.0, 0.0);
    run(&mut sim, 2.0, action(0.0, 0.0, 0.0));
    sim.set_velocity(Vector3::new(10.0, 2.0, 0.0));
    let e0 = sim.kinetic_energy();
    let mut max_e: f64 = 0.0;
    for _ in 0..(5.0 / sim.dt()) as usize {
        sim.step(&action(0.0, 0.3, 0.0));
        max_e = max_e.max(sim.kinetic_energy());
    }
    assert!(
        max_e <= 1.005 * e0,
        "energy grew from {e0:.0} J to {max_e:.0} J"
    );
}

#[test]
fn a_wheel_climbs_a_step_and_the_chassis_high_centres_on_a_crest() {
    // A 0.3 m step (below the 0.467 m wheel radius) is climbed; a 1.2 m-high sharp ridge leaves the HMMWV hung on
    // its belly (it stops on the crest).
    let step = world_with(
        |x, _| if x > 0.0 { 0.3 } else { 0.0 },
        Surface::Rigid { friction: 0.8 },
    );
    let mut sim = Simulation::new(&step, &hmmwv(), -10.0, 0.0, 0.0);
    for _ in 0..(12.0 / sim.dt()) as usize {
        let v = sim.state().speed;
        sim.step(&action(if v < 2.0 { 0.6 } else { 0.0 }, 0.0, 0.0));
    }
    assert!(
        sim.position().x > 5.0,
        "stuck at the step: x = {:.2}",
        sim.position().x
    );
    let ridge = world_with(
        |x, _| (1.2 - 0.8 * x.abs()).max(0.0),
        Surface::Rigid { friction: 0.8 },
    );
    let mut sim = Simulation::new(&ridge, &hmmwv(), -10.0, 0.0, 0.0);
    for _ in 0..(20.0 / sim.dt()) as usize {
        let v = sim.state().speed;
        sim.step(&action(if v < 1.5 { 0.5 } else { 0.0 }, 0.0, 0.0));
    }
    assert!(
        sim.position().x.abs() < 2.5,
        "should hang on the crest, x = {:.2}",
        sim.position().x
    );
}

#[test]
fn a_wheel_leaving_a_rut_for_rigid_ground_climbs_out_instead_of_being_launched() {
    // Flat ground, snow west of x = 0 and concrete east of it. In snow the HMMWV's wheels sink (Bekker: 0.36 m for a
    // towed wheel, see tests/soil_wheel_theory.rs), so at the patch edge each wheel meets the rigid surface above its
    // rim. It must roll out of the rut like up a short ramp (rising half a metre per metre): the front rises by the
    // rut's depth while the rear is still in it (about atan(0.35 / 3.38) = 6 degrees of pitch, roughly doubled by
    // the chassis' pitch response at 5 m/s: bound 20 degrees, far from a flip) and rises at no more than about half
    // the speed (bound 0.5 v + 0.5 m/s). Before the rut-exit rule the stiff tyre fired the wheels out of the ground: the HMMWV
    // flipped end over end here at 2 and at 5 m/s (pitch 90 degrees, vertical speed about 5 m/s), as it did on gentle
    // terrain in the benchmark's mixed worlds.
    let mut w = world_with(|_, _| 0.0, Surface::Rigid { friction: 0.8 });
    for (k, p) in w.patches.iter_mut().enumerate() {
        if k % sim_core::world::PATCHES < sim_core::world::PATCHES / 2 {
            p.semantic = sim_core::world::Semantic::Snow;
            p.surface = Surface::Deformable {
                soil: sim_core::world::SoilParams::SNOW,
            };
        }
    }
    assert!(matches!(
        w.patch_at(-1.0, 0.0).surface,
        Surface::Deformable { .. }
    ));
    assert!(matches!(
        w.patch_at(1.0, 0.0).surface,
        Surface::Rigid { .. }
    ));
    for target in [2.0, 5.0] {
        let mut sim = Simulation::new(&w, &hmmwv(), -25.0, 0.0, 0.0);
        let (mut max_pitch, mut max_vz, mut min_z_in_snow) = (0.0f64, 0.0f64, f64::INFINITY);
        for _ in 0..(40.0 / sim.dt()) as usize {
            let s = sim.state();
            if s.position[0] > 12.0 {
                break;
            }
            sim.step(&action(
                ((target - s.speed) * 0.5).clamp(0.0, 1.0),
                0.0,
                0.0,
            ));
            let s = sim.state();
            if s.position[0] > -12.0 {
                max_pitch = max_pitch.max(s.pitch.abs().to_degrees());
                max_vz = max_vz.max(s.velocity[2].abs());
            }
            if s.position[0] < -5.0 && s.position[0] > -12.0 {
                min_z_in_snow = min_z_in_snow.min(s.position[2]);
            }
        }
        let x = sim.position().x;
        eprintln!(
            "{target} m/s: pitch up to {max_pitch:.1} deg, |vz| up to {max_vz:.2} m/s, rut {:.3} m",
            sim.position().z - min_z_in_snow
        );
        assert!(
            x > 10.0,
            "{target} m/s: did not cross onto concrete, x = {x:.1}"
        );
        assert!(
            max_pitch < 20.0 && max_vz < 0.5 * target + 0.5,
            "{target} m/s: launched at the rut's edge: |pitch| up to {max_pitch:.1} deg, |vz| up to {max_vz:.2} m/s"
        );
        // The wheels did sink in the snow (the chassis rides lower there than on concrete).
        assert!(
            sim.position().z - min_z_in_snow > 0.1,
            "{target} m/s: no sinkage in snow (z {min_z_in_snow:.3} vs {:.3})",
            sim.position().z
        );
    }
}
