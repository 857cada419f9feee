//! The HMMWV's engine as Chrono's `HMMWV_EngineSimpleMap` (Chrono 7689fbc,
//! `chrono_models/vehicle/hmmwv/powertrain/HMMWV_EngineSimpleMap.cpp`): its two torque maps, the 2700 rpm clamp
//! that makes the full-load map's negative tail a speed governor, and engine braking at a closed throttle
//! (`ChEngineSimpleMap::Synchronize`: `u full + (1 - u) zero`, both read at `min(speed, max)`).

mod common;
use common::*;
use sim_core::characterize::{test_world, Ground};
use sim_core::vehicle::vehicle_by_name;
use sim_core::{Simulation, VehicleSpec};
use std::f64::consts::TAU;

#[test]
fn the_maps_are_chrono_s_and_read_at_the_clamped_speed() {
    let p = vehicle_by_name("hmmwv").unwrap().powertrain;
    // Points of Chrono's maps, exactly; between points linear; beyond 2700 rpm the value at 2700.
    for (rpm, full, zero) in [
        (800.0, 517.9, -20.0),
        (1500.0, 1300.2, -30.0),
        (2200.0, 1041.3, -70.0),
        (2300.0, (1041.3 - 271.2) / 2.0, -85.0),
        (2700.0, -800.0, -800.0),
        (4000.0, -800.0, -800.0),
    ] {
        assert!((p.full_load(rpm) - full).abs() < 1e-9, "full load at {rpm}");
        assert!(
            (p.closed_throttle(rpm).unwrap() - zero).abs() < 1e-9,
            "closed at {rpm}"
        );
    }
}

/// Coasting in gear on flat rigid ground, the engine's closed-throttle torque `T0(rpm)` reaches the wheels
/// multiplied by the gearbox and final drive (`1 / ratio`) and decelerates the vehicle by `T0 / (ratio r m_eff)`
/// (Newton, with `m_eff = 2 KE / v^2` taking in the wheels' spin), on top of whatever else slows it. Measured as
/// the difference from the same vehicle without the map, whose coast is otherwise identical. Tolerance 10%.
#[test]
fn a_closed_throttle_brakes_the_vehicle_by_the_engine_s_map() {
    let with = vehicle_by_name("hmmwv").unwrap();
    let mut without = with.clone();
    without.powertrain.zero_throttle_curve = None;
    let coast = |spec: &VehicleSpec| {
        let mut sim = Simulation::new(&flat(0.9), spec, -60.0, 0.0, 0.0);
        run(&mut sim, 4.0, action(1.0, 0.0, 0.0));
        let (v0, gear) = (sim.state().speed, sim.gear());
        let mut predicted = 0.0;
        let steps = (1.5 / sim.dt()).round() as usize;
        for _ in 0..steps {
            let p = &spec.powertrain;
            let ratio = p.gears[sim.gear()] * p.final_drive;
            let spins: Vec<f64> = sim.wheel_spins().collect();
            let spin = spins.iter().map(|w| w.abs()).sum::<f64>() / spins.len() as f64;
            let rpm = spin / ratio * 60.0 / TAU;
            let v = sim.state().speed;
            let m_eff = 2.0 * sim.kinetic_energy() / (v * v);
            let t0 = p.closed_throttle(rpm).unwrap_or(0.0);
            predicted += t0 / ratio / spec.wheels.radius / m_eff * sim.dt();
            sim.step(&action(0.0, 0.0, 0.0));
        }
        assert_eq!(sim.gear(), gear, "the coast stays in one gear");
        (sim.state().speed - v0, predicted, v0, gear)
    };
    let (dv_with, predicted, v0, gear) = coast(&with);
    let (dv_without, _, _, _) = coast(&without);
    let extra = dv_with - dv_without;
    eprintln!(
        "from {v0:.2} m/s in gear {}: {dv_with:.4} m/s with the map, {dv_without:.4} without, predicted {predicted:.4}",
        gear + 1
    );
    assert!(predicted < -0.1, "the map brakes measurably: {predicted}");
    assert!(
        (extra - predicted).abs() <= 0.10 * predicted.abs(),
        "engine braking took {extra:.4} m/s, the map predicts {predicted:.4}"
    );
}

/// Full throttle on flat rigid ground: the full-load map crosses zero at 2358.7 rpm (between 1041.3 N m at 2200
/// and -271.2 at 2400), which in top gear (1.5361, final drive 0.2) on a 0.467 m wheel is 35.44 m/s: the vehicle
/// closes on that speed and does not pass it (the old map, zero at 2800 rpm, allowed 42 m/s).
#[test]
fn full_throttle_is_governed_where_the_full_load_map_crosses_zero() {
    let spec = vehicle_by_name("hmmwv").unwrap();
    let p = &spec.powertrain;
    let crossing = 2200.0 + 200.0 * 1041.3 / (1041.3 + 271.2);
    assert!(p.full_load(crossing).abs() < 1e-9);
    let top_ratio = p.gears[p.gears.len() - 1] * p.final_drive;
    let governed = crossing * TAU / 60.0 * top_ratio * spec.wheels.radius;
    let world = test_world(Ground::Rigid { friction: 0.9 }, 0.0, 1.0);
    let mut sim = Simulation::new(&world, &spec, -480.0, 0.0, 0.0);
    let mut fastest: f64 = 0.0;
    for _ in 0..(28.0 / sim.dt()).round() as usize {
        sim.step(&action(1.0, 0.0, 0.0));
        fastest = fastest.max(sim.state().speed);
    }
    eprintln!("fastest {fastest:.3} m/s, governed at {governed:.3}");
    assert!(
        fastest <= governed * 1.002,
        "{fastest:.3} m/s passes the governed {governed:.3} m/s"
    );
    assert!(
        fastest >= governed * 0.97,
        "{fastest:.3} m/s is well short of the governed {governed:.3} m/s"
    );
}
