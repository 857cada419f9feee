//! `vb sim characterize`: the datasheet command end to end (the binary, its JSON, its errors).

use std::ffi::OsStr;
use std::process::Command;

/// Runs `vb` with `args`, which must succeed; returns its standard output.
fn vb_ok<S: AsRef<OsStr>>(args: impl IntoIterator<Item = S>) -> Vec<u8> {
    let out = Command::new(integration::vb()).args(args).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

#[test]
fn characterize_prints_a_datasheet_whose_braking_is_mu_g() {
    let out = vb_ok([
        "sim",
        "characterize",
        "--vehicle",
        "hmmwv",
        "--surface",
        "rigid",
        "--json",
    ]);
    let sheets: serde_json::Value = serde_json::from_slice(&out).unwrap();
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
    let out = vb_ok(["sim", "characterize", "--surface", "rigid"]);
    let text = String::from_utf8_lossy(&out);
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
        let out = Command::new(integration::vb())
            .args(["sim", "characterize"])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(args[1]) || err.contains("--dt"), "{err}");
    }
}

/// `--task-dir`: the move-off check from every start of the release's 10 original worlds (imported as a user would).
/// Needs `VB_RELEASE_DIR` (CI sets it); skipped otherwise. Under sim-core r10 the HMMWV cannot leave 12 of the 100
/// starts, on the two high worlds and three medium ones (r9: 11, r8: 9; BENCHMARKS.md, "Chrono side by side");
/// it leaves every start of the low worlds.
#[test]
fn characterize_counts_the_starts_a_vehicle_cannot_move_off_from() {
    let Some(release) = std::env::var_os("VB_RELEASE_DIR") else {
        eprintln!("SKIPPED: VB_RELEASE_DIR is not set, so the move-off check was not run on the release's worlds");
        return;
    };
    let dir = integration::temp_dir("move-off");
    let tasks = dir.join("orig-tasks");
    let maps = std::path::PathBuf::from(release).join("BenchMaps/sampled_maps");
    vb_ok([
        OsStr::new("tasks"),
        OsStr::new("import-verti-bench"),
        maps.as_os_str(),
        OsStr::new("--out"),
        tasks.as_os_str(),
    ]);
    // Beside a reference that lists two of the starts (issue 59, item 4: the Chrono harness's `move-off`): one it
    // says is stranded, one it says moved.
    let reference = dir.join("reference.json");
    std::fs::write(
        &reference,
        r#"{"datasheets": [], "move_off": {"tasks": [{"task": "w005-t0", "distance": 0.5}, {"task": "w001-t3", "distance": 88.0}]}}"#,
    )
    .unwrap();
    let out = vb_ok([
        OsStr::new("sim"),
        OsStr::new("characterize"),
        OsStr::new("--surface"),
        OsStr::new("rigid"),
        OsStr::new("--json"),
        OsStr::new("--task-dir"),
        tasks.as_os_str(),
        OsStr::new("--reference"),
        reference.as_os_str(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(v["datasheets"][0]["surface"], "rigid");
    assert_eq!(v["move_off"]["starts"], 100);
    let rows = v["move_off"]["tasks"].as_array().unwrap();
    assert_eq!(rows.len(), 100);
    let distance = |id: &str| {
        rows.iter()
            .find(|r| r["task"] == id)
            .and_then(|r| r["distance"].as_f64())
            .unwrap()
    };
    let a = &v["move_off_agreement"];
    assert_eq!(a["not_in_reference"].as_array().unwrap().len(), 98, "{a}");
    assert_eq!(a["starts"][0]["task"], "w001-t3", "in our task order");
    assert_eq!(a["starts"][0]["ours"].as_f64(), Some(distance("w001-t3")));
    // w005 is a low world: we move off from it, the reference says stranded.
    assert!(distance("w005-t0") >= 5.0);
    let counted = a["both_moved"].as_u64().unwrap()
        + a["only_ours_stranded"].as_u64().unwrap()
        + a["only_reference_stranded"].as_u64().unwrap()
        + a["both_stranded"].as_u64().unwrap();
    assert_eq!(counted, 2, "{a}");
    assert!(a["only_reference_stranded"].as_u64().unwrap() >= 1, "{a}");
    let stuck: Vec<&str> = v["move_off"]["stuck"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s.as_str().unwrap())
        .collect();
    // The sample's low worlds (gentle relief): every start is left.
    let low = ["w005-", "w009-", "w093-", "w096-"];
    assert!(
        stuck
            .iter()
            .all(|id| !low.iter().any(|w| id.starts_with(w))),
        "{stuck:?}"
    );
    assert!(
        !stuck.is_empty() && stuck.len() <= 20,
        "stuck at {} of 100 starts: {stuck:?}",
        stuck.len()
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Issue 59, item 2: `--reference FILE` prints every figure beside the reference's. Our own datasheet as the
/// reference is within tolerance everywhere (ratio 1); one with a grade 5 degrees off and a distance 25% off fails
/// those two; a file of another schema is refused before anything runs.
#[test]
fn characterize_compares_with_a_reference_file() {
    let dir = integration::temp_dir("characterize-reference");
    let ours = vb_ok(["sim", "characterize", "--surface", "rigid", "--json"]);
    let mut reference: serde_json::Value = serde_json::from_slice(&ours).unwrap();
    let same = dir.join("same.json");
    std::fs::write(&same, serde_json::to_string(&reference).unwrap()).unwrap();
    let text = String::from_utf8(vb_ok([
        OsStr::new("sim"),
        OsStr::new("characterize"),
        OsStr::new("--surface"),
        OsStr::new("rigid"),
        OsStr::new("--reference"),
        same.as_os_str(),
    ]))
    .unwrap();
    let last = text.lines().last().unwrap_or("");
    let (within, compared) = last
        .split_once(" of ")
        .map(|(a, b)| (a.to_string(), b.split(' ').next().unwrap_or("").to_string()))
        .unwrap();
    assert_eq!(within, compared, "{text}");
    assert!(!text.contains(" NO"), "{text}");
    let d = &mut reference["datasheets"][0];
    let grade = d["climb_grade_deg"].as_f64().unwrap();
    d["climb_grade_deg"] = serde_json::json!(grade + 5.0);
    let distance = d["distance_20s"].as_f64().unwrap();
    d["distance_20s"] = serde_json::json!(distance / 1.25 / 1.01);
    let off = dir.join("off.json");
    std::fs::write(&off, serde_json::to_string(&reference).unwrap()).unwrap();
    let out = vb_ok([
        OsStr::new("sim"),
        OsStr::new("characterize"),
        OsStr::new("--surface"),
        OsStr::new("rigid"),
        OsStr::new("--json"),
        OsStr::new("--reference"),
        off.as_os_str(),
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out).unwrap();
    let failed: Vec<&str> = v["comparison"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|r| {
            let (o, r2) = (r["ours"].as_f64(), r["reference"].as_f64());
            match (o, r2, r["tolerance"].as_str()) {
                (Some(o), Some(x), Some("angle")) => (o - x).abs() > 4.0,
                (Some(o), Some(x), _) => ((o - x) / x).abs() > 0.2,
                _ => false,
            }
        })
        .map(|r| r["figure"].as_str().unwrap())
        .collect();
    assert_eq!(failed, ["distance_20s", "climb_grade_deg"], "{v}");
    let bad = dir.join("bad.json");
    std::fs::write(&bad, "[1, 2]").unwrap();
    let out = Command::new(integration::vb())
        .args(["sim", "characterize", "--reference"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("bad.json") && err.contains("datasheets"),
        "{err}"
    );
    // A reference of move-off starts wants the task set they ran on; a malformed start is named.
    for (text, says) in [
        (
            r#"{"datasheets": [], "move_off": {"tasks": [{"task": "w001-t0", "distance": 3}]}}"#,
            "--task-dir",
        ),
        (
            r#"{"datasheets": [], "move_off": {"tasks": [{"task": "w001-t0"}]}}"#,
            "move_off.tasks[0]",
        ),
    ] {
        std::fs::write(&bad, text).unwrap();
        let out = Command::new(integration::vb())
            .args(["sim", "characterize", "--reference"])
            .arg(&bad)
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `vb sim climb`: the grade scenario with a per-wheel trace in the Chrono harness's columns (issue 59, item 3);
/// its verdict is the datasheet's criterion, and bad input is refused before anything runs.
#[test]
fn climb_writes_a_per_wheel_trace_in_the_harness_columns() {
    let dir = integration::temp_dir("climb-trace");
    let trace = dir.join("trace.csv");
    let out = String::from_utf8(vb_ok([
        OsStr::new("sim"),
        OsStr::new("climb"),
        OsStr::new("--surface"),
        OsStr::new("rigid"),
        OsStr::new("--grade"),
        OsStr::new("10,50"),
        OsStr::new("--every"),
        OsStr::new("1"),
        OsStr::new("--trace"),
        trace.as_os_str(),
    ]))
    .unwrap();
    // 50 degrees is beyond atan(0.85) = 40.4: no tyre can hold it.
    assert!(
        out.contains("rigid 10 deg: climbs") && out.contains("rigid 50 deg: does not climb"),
        "{out}"
    );
    let text = std::fs::read_to_string(&trace).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let harness = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tools/chrono-reference/measured/snow-climb-nsc-5ms.csv"),
    )
    .unwrap();
    assert_eq!(
        header,
        harness.lines().next().unwrap(),
        "the harness's columns"
    );
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert_eq!(
        rows.len(),
        2 * 20 * 4,
        "two grades, every 1 s for 20 s, four wheels"
    );
    assert!(rows.iter().all(|r| r.len() == 19), "19 columns");
    // The soil's moment only on soil: empty on rigid ground.
    assert!(rows.iter().all(|r| r[14].is_empty()), "moment off soil");
    assert_eq!(
        (rows[0][0], rows[0][2], rows[3][2]),
        ("10", "front_left", "rear_right")
    );
    for (args, says) in [
        (vec!["--surface", "snow", "--grade", "70"], "--grade"),
        (vec!["--surface", "ice", "--grade", "10"], "ice"),
        (
            vec!["--surface", "rigid", "--grade", "10", "--every", "0"],
            "--every",
        ),
    ] {
        let out = Command::new(integration::vb())
            .args(["sim", "climb"])
            .args(&args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{args:?}: {err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
