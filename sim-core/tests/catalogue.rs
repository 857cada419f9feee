//! Every vehicle of the catalogue parses, and drives a simple path to its goal on flat ground at its own scale.

mod common;
use common::*;
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::vehicle::{builtin_vehicles, vehicle_by_name, VehicleSpec};
use sim_core::world::Task;

#[test]
fn catalogue_has_nine_vehicles_of_every_scale_and_kind() {
    let all = builtin_vehicles();
    assert_eq!(all.len(), 9);
    for scale in [1.0, 0.16667, 0.1] {
        assert!(
            all.iter().any(|v| (v.scale - scale).abs() < 1e-4),
            "no vehicle at scale {scale}"
        );
    }
    for wheels in [2, 3, 4] {
        assert!(
            all.iter()
                .any(|v| v.axles.len() == wheels && v.tracks.is_none()),
            "no {}-wheeled vehicle",
            2 * wheels
        );
    }
    assert!(all.iter().any(|v| v.tracks.is_some()));
    assert!(vehicle_by_name("nope")
        .unwrap_err()
        .to_string()
        .contains("hmmwv"));
}

#[test]
fn bad_vehicle_files_name_the_file_and_field() {
    let text = include_str!("../vehicles/hmmwv.toml");
    let e = VehicleSpec::parse_toml(&text.replace("mass = 2493.6", "mass = -1.0"), "x.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("x.toml") && e.contains("chassis"), "{e}");
    let e = VehicleSpec::parse_toml(
        &text.replace("radius = 0.467", "radius = \"big\""),
        "y.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("y.toml"), "{e}");
    let e = VehicleSpec::parse_toml(
        &text.replace("[steering]", "bogus = 1\n[steering]"),
        "z.toml",
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("bogus"), "{e}");
    // The engine's maps and speed clamp.
    for (from, to, field) in [
        ("max_rpm = 2700.0", "max_rpm = -5.0", "powertrain.max_rpm"),
        ("max_rpm = 2700.0", "max_rpm = nan", "powertrain.max_rpm"),
        (
            "zero_throttle_curve = [[-100.0, 0.0], [800.0, -20.0]",
            "zero_throttle_curve = [[800.0, 0.0], [800.0, -20.0]",
            "powertrain.zero_throttle_curve",
        ),
        (
            "torque_curve = [[-100.0, 406.7]",
            "torque_curve = [[-100.0, inf]",
            "powertrain.torque_curve",
        ),
    ] {
        assert!(text.contains(from), "{from}");
        let e = VehicleSpec::parse_toml(&text.replacen(from, to, 1), "e.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("e.toml") && e.contains(field), "{to}: {e}");
    }
}

#[test]
fn every_vehicle_reaches_the_goal_on_flat_ground() {
    for spec in builtin_vehicles() {
        let s = spec.scale;
        let w = flat(0.8).scaled(s);
        let task = Task {
            world_id: 1,
            index: 0,
            start: [-50.0 * s, 0.0],
            goal: [50.0 * s, 30.0 * s],
            path: vec![[-50.0 * s, 0.0], [0.0, 0.0], [50.0 * s, 30.0 * s]],
        };
        let mut p = sim_core::control::PurePursuit::new();
        let r = sim_core::run_episode(&w, &task, &spec, &mut p, &EpisodeConfig::default());
        assert_eq!(
            r.outcome,
            Outcome::Success,
            "{}: {} {}",
            spec.name,
            r.reason,
            r.detail
        );
        // The path is 108 m at full scale; the driven one is a little longer but not a detour.
        assert!(
            r.metrics.path_length < 1.2 * 108.0 * s,
            "{}: drove {:.1} m",
            spec.name,
            r.metrics.path_length
        );
    }
}
