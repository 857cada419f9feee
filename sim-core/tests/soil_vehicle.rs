//! The whole vehicle on soft soil against the single-wheel theory and its own step: the steepest climbable grade,
//! static equilibrium (settling, sinkage, no creep), contact stability while parked, convergence in the time step.
//! Each test states its source and tolerance.

mod common;
use common::action;
use sim_core::characterize::{self, Ground, Setup};
use sim_core::soil::rig::{bekker_static_sinkage, predicted_grade_deg};
use sim_core::vehicle::{default_dt, vehicle_by_name, SimOptions};
use sim_core::world::SoilParams;
use sim_core::Simulation;

const SOILS: [(Ground, SoilParams); 3] = [
    (Ground::Snow, SoilParams::SNOW),
    (Ground::Mud, SoilParams::MUD),
    (Ground::Sand, SoilParams::SAND),
];

#[test]
fn the_steepest_climbable_grade_is_the_single_wheel_prediction() {
    // Wong, Theory of Ground Vehicles (grade resistance against drawbar pull): an all-wheel-driven vehicle climbs up
    // to the grade where its drawbar pull per weight at the best slip reaches tan(grade). The prediction is the
    // single-wheel rig (sim_core::soil::rig, validated against Bekker and Wong-Reece in soil_wheel_theory.rs) with
    // the HMMWV's wheel at its mean static load on fresh soil (at the climbing limit the wheels spin nearly in
    // place, each in its own hole), converged in grid and step (0.025 m, 1 ms): on the benchmark's 0.1 m grid the
    // rig's pull on snow is 0.04 W low (grid error, soil_wheel_theory.rs), a 2.3 degree error on its own.
    // Tolerance 2 degrees (issue 13). The vehicle's grade is found by bisection to 0.1 degree.
    let spec = vehicle_by_name("hmmwv").unwrap();
    let load = spec.chassis.mass * 9.81 / 4.0;
    for (ground, soil) in SOILS {
        let predicted = predicted_grade_deg(
            soil,
            spec.wheels.radius,
            spec.wheels.width,
            load,
            1e-3,
            0.025,
            1,
        );
        let climbed = characterize::climb_grade(&spec, &Setup { ground, dt: None });
        eprintln!(
            "{}: climbs {climbed:.2} deg, single-wheel prediction {predicted:.2} deg",
            ground.name()
        );
        assert!(
            (climbed - predicted).abs() <= 2.0,
            "{}: climbs {climbed:.2} deg, predicted {predicted:.2}",
            ground.name()
        );
    }
}

#[test]
fn a_braked_vehicle_settles_on_soil_and_then_stays_put() {
    // Static equilibrium (issue 13): a braked vehicle on flat soil settles, then sinks less than 2 mm and creeps less
    // than 1 cm in the next 30 s, and its rims stay in the soil (contact lost in under 1% of the wheel-steps: no
    // chatter). Settling (`Simulation::settle`: weight ramped on over 2 s, then still below 2 mm/s for 1 s) must
    // take less than 5 s (it takes about 3).
    //
    // Each HMMWV wheel's static sinkage (its rim's depth below the undeformed surface) is compared with the
    // plate-sinkage equilibrium under its load: the rigid wheel pressed statically into Bekker soil,
    // p = (k_c / b + k_phi) z^n integrated over the contact chord (Bekker; Wong, Theory of Ground Vehicles, the
    // static rigid wheel), solved for the wheel's load. Tolerance 10% on every soil (issue 13).
    for vehicle in ["hmmwv", "m113"] {
        let spec = vehicle_by_name(vehicle).unwrap();
        for (ground, soil) in SOILS {
            let world = characterize::test_world(ground, 0.0, spec.scale);
            let mut sim = Simulation::new(&world, &spec, 0.0, 0.0, 0.0);
            let settle = sim.settle_time();
            let (p0, z0) = (sim.position(), characterize::mean_sinkage(&sim));
            let (mut lost, mut wheel_steps) = (0usize, 0usize);
            for _ in 0..(30.0 / sim.dt()).round() as usize {
                sim.step(&action(0.0, 0.0, 1.0));
                lost += sim.wheels().filter(|w| !w.contact).count();
                wheel_steps += sim.wheels().count();
            }
            let sink = characterize::mean_sinkage(&sim) - z0;
            let creep = (sim.position() - p0).xy().norm();
            let lost = lost as f64 / wheel_steps as f64;
            eprintln!(
                "{vehicle} on {}: settled in {settle:.2} s, sinkage {z0:.4} m, then {:.2} mm deeper, {:.2} mm creep, rim contact lost {:.2}%",
                ground.name(),
                sink * 1e3,
                creep * 1e3,
                lost * 100.0
            );
            assert!(
                settle < 5.0,
                "{vehicle} on {}: settling took {settle} s",
                ground.name()
            );
            assert!(
                sink.abs() < 2e-3,
                "{vehicle} on {}: sank {sink} m more",
                ground.name()
            );
            assert!(
                creep < 1e-2,
                "{vehicle} on {}: crept {creep} m",
                ground.name()
            );
            assert!(
                lost < 0.01,
                "{vehicle} on {}: lost contact in {lost} of wheel-steps",
                ground.name()
            );
            if vehicle == "hmmwv" {
                for w in sim.wheels() {
                    let want = bekker_static_sinkage(
                        soil,
                        spec.wheels.radius,
                        spec.wheels.width,
                        w.normal_load,
                    );
                    eprintln!(
                        "  wheel sinkage {:.4} m under {:.0} N, Bekker {want:.4} m ({:+.1}%)",
                        w.sinkage,
                        w.normal_load,
                        (w.sinkage / want - 1.0) * 100.0
                    );
                    assert!(
                        (w.sinkage - want).abs() <= 0.10 * want,
                        "hmmwv on {}: wheel sinkage {:.4} m under {:.0} N, Bekker {want:.4} m",
                        ground.name(),
                        w.sinkage,
                        w.normal_load
                    );
                }
            }
        }
    }
}

#[test]
fn sinkage_distance_and_grade_converge_in_the_time_step() {
    // Convergence (issue 13): settled sinkage, the distance covered in 20 s of full throttle and the steepest
    // climbable grade agree within 5% between the default step (4 ms) and a quarter of it (1 ms), on every soil.
    // (At the 20 s speeds, 28-41 m/s, the soil's damping pressure R |v . N| lifts the wheels to a few centimetres of
    // sinkage; sim-core r5's whole-cell damping and whole-step first shear made the snow distance 5.9% apart, r6's
    // 1.1%.)
    let spec = vehicle_by_name("hmmwv").unwrap();
    let dt = default_dt(1.0);
    for (ground, _) in SOILS {
        let measure = |dt: f64| {
            let setup = Setup {
                ground,
                dt: Some(dt),
            };
            let world = characterize::test_world(ground, 0.0, 1.0);
            let options = SimOptions {
                dt: Some(dt),
                ..SimOptions::default()
            };
            let sim = Simulation::with_options(&world, &spec, 0.0, 0.0, 0.0, &options);
            let sinkage = characterize::mean_sinkage(&sim);
            let (_, distance) = characterize::full_throttle(&spec, &setup);
            let grade = characterize::climb_grade(&spec, &setup);
            [sinkage, distance, grade]
        };
        let (a, b) = (measure(dt), measure(dt / 4.0));
        eprintln!(
            "{}: [sinkage m, 20 s distance m, grade deg] at {dt} s {a:?}, at {} s {b:?}",
            ground.name(),
            dt / 4.0
        );
        for (k, name) in ["sinkage", "distance", "grade"].iter().enumerate() {
            assert!(
                (a[k] - b[k]).abs() <= 0.05 * b[k].abs(),
                "{}: {name} {} at {dt} s vs {} at {} s",
                ground.name(),
                a[k],
                b[k],
                dt / 4.0
            );
        }
    }
}
