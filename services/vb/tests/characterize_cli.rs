//! `vb sim characterize`: the datasheet command end to end (the binary, its JSON, its errors).

mod common;
use std::process::Command;

#[test]
fn characterize_prints_a_datasheet_whose_braking_is_mu_g() {
    let out = Command::new(common::vb())
        .args([
            "sim",
            "characterize",
            "--vehicle",
            "hmmwv",
            "--surface",
            "rigid",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let sheets: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let d = &sheets["datasheets"][0];
    assert!(sheets["move_off"].is_null());
    assert_eq!(d["vehicle"], "hmmwv");
    assert_eq!(d["surface"], "rigid");
    // Rigid ground at concrete's mean mu 0.85 (below the tyre's 0.9): every wheel locked decelerates at mu g
    // (Newton; 3% as issue 13's braking test).
    let braking = d["braking_decel_g"].as_f64().unwrap();
    assert!((braking - 0.85).abs() < 0.03 * 0.85, "braking {braking} g");
    // Steepest grade: at most atan(mu) = 40.4 degrees on rigid ground, and the HMMWV's engine gets close to it.
    let grade = d["climb_grade_deg"].as_f64().unwrap();
    assert!(grade <= 40.7 && grade > 30.0, "grade {grade}");
    // Speeds rise with time under full throttle; the full-steer circle is tighter than the half-steer one.
    let speeds: Vec<f64> = (0..4)
        .map(|k| d["speed_at"][k][1].as_f64().unwrap())
        .collect();
    assert!(speeds.windows(2).all(|w| w[1] > w[0]), "{speeds:?}");
    let (half, full) = (
        d["turn_radius_half"].as_f64().unwrap(),
        d["turn_radius_full"].as_f64().unwrap(),
    );
    assert!(full < half, "radius half {half} full {full}");
    // The table form names every scenario.
    let out = Command::new(common::vb())
        .args(["sim", "characterize", "--surface", "rigid"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    for row in [
        "static sinkage",
        "distance at 20 s",
        "steepest grade",
        "side slope: tips",
        "turn radius, full steer",
    ] {
        assert!(text.contains(row), "{row} missing:\n{text}");
    }
}

#[test]
fn characterize_rejects_unknown_surfaces_and_vehicles() {
    for args in [["--surface", "lava"], ["--vehicle", "tank"], ["--dt", "-1"]] {
        let out = Command::new(common::vb())
            .args(["sim", "characterize"])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(args[1]) || err.contains("--dt"), "{err}");
    }
}
