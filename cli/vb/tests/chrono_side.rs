//! The commands beside the Chrono harness (issue 59): `vb sim roll-back` (the harness's `roll-back`) and `vb bench
//! move-off --reference` (sim-core timed on the harness's starts).

use std::process::Command;

fn vb(args: &[&str]) -> std::process::Output {
    Command::new(integration::vb()).args(args).output().unwrap()
}

/// Released on an 8 deg rigid plane facing uphill with no throttle, the HMMWV rolls back, but more slowly than a
/// free-rolling vehicle (g sin 8 deg = 1.37 m/s^2, Wong 3.1): its engine's closed-throttle map brakes it (Chrono's
/// pushes it: BENCHMARKS.md, "The engine map: sim-core r10").
#[test]
fn a_released_vehicle_rolls_back_engine_braked() {
    let out = vb(&["sim", "roll-back", "--grade", "8", "--seconds", "4"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("t,speed,engine_speed,engine_torque,gear")
    );
    let rows: Vec<(f64, f64)> = lines
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[0].parse().unwrap(), c[1].parse().unwrap())
        })
        .collect();
    // Every 0.25 s rounded to whole steps (63 of 4 ms) for 4 s.
    assert!((15..=17).contains(&rows.len()), "{} samples", rows.len());
    let (t, v) = *rows.last().unwrap();
    let free = 9.81 * 8f64.to_radians().sin();
    assert!(v < -1.0, "it rolls back: {v} m/s at {t} s");
    assert!(
        -v / t < 0.9 * free,
        "engine-braked: {} against {free} m/s^2",
        -v / t
    );
    let bad = vb(&["sim", "roll-back", "--grade", "70"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--grade"));
}

/// `vb bench move-off` times the starts the reference ran, and refuses a reference of other starts.
#[test]
fn bench_move_off_times_the_reference_s_starts() {
    let dir = integration::temp_dir("bench-move-off");
    let tasks: Vec<String> = (0..10)
        .map(|k| format!("{{\"task\": \"w001-t{k}\", \"distance\": 50}}"))
        .collect();
    let json = |tasks: &[String]| {
        format!(
            "{{\"reference\": {{\"simulator\": \"Chrono 10.0.0\"}}, \"datasheets\": [], \"move_off\": {{\"starts\": {}, \"wall_s\": 30, \"stuck\": [], \"tasks\": [{}]}}}}",
            tasks.len(),
            tasks.join(", ")
        )
    };
    let same = dir.join("same.json");
    std::fs::write(&same, json(&tasks)).unwrap();
    let out = vb(&[
        "bench",
        "move-off",
        "--worlds",
        "1",
        "--reference",
        same.to_str().unwrap(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("10 starts in") && text.contains("Chrono 10.0.0: 10 starts in 30.0 s"),
        "{text}"
    );
    assert!(text.contains("times faster"), "{text}");
    let other = dir.join("other.json");
    std::fs::write(&other, json(&tasks[..3])).unwrap();
    let out = vb(&[
        "bench",
        "move-off",
        "--worlds",
        "1",
        "--reference",
        other.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("other starts"));
    let out = vb(&["bench", "move-off", "--worlds", "x1"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--worlds"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `vb sim drive` speaks the lock-step protocol on stdin and stdout (`eval::external`): it names itself, acts on the
/// first state, and a simulator that hangs up before the episode ended is a clear error.
#[test]
fn sim_drive_acts_on_states_and_names_a_broken_pipe() {
    use std::io::Write;
    let mut child = Command::new(integration::vb())
        .args(["sim", "drive", "--task", "w001-t0", "--planner", "pid"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin
        .write_all(b"dt 0.005\nstate 0 0 0 1 0 0 0 0 0 0 0 0 0 0 0\n")
        .unwrap();
    drop(stdin);
    let out = child.wait_with_output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    let mut lines = text.lines();
    let ok = lines.next().unwrap_or("");
    assert!(
        ok.starts_with("ok {")
            && ok.contains("\"planner\":\"pid\"")
            && ok.contains("\"control_every\":10"),
        "{text}"
    );
    assert!(
        lines.next().is_some_and(|l| l.starts_with("act ")),
        "{text}"
    );
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("driving w001-t0") && err.contains("closed the pipe after 2 lines"),
        "{err}"
    );
    let bad = vb(&["sim", "drive", "--task", "w1-t0"]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("is not a task id"));
}

/// `vb sim episodes` drives the reference's tasks with its planner and rules and lists both outcome by outcome.
#[test]
fn sim_episodes_lists_both_simulators_outcomes() {
    let dir = integration::temp_dir("sim-episodes");
    let config = serde_json::to_string(&sim_core::episode::EpisodeConfig::default()).unwrap();
    let reference = format!(
        "{{\"reference\": {{\"simulator\": \"Chrono 10.0.0\"}}, \"datasheets\": [], \"episodes\": {{\"driver\": \
         {{\"planner\": \"pid\", \"config\": {config}, \"control_every\": 10}}, \"tasks\": [\
         {{\"task\": \"w001-t0\", \"outcome\": \"success\", \"reason\": \"success\", \"time\": 20.5}}, \
         {{\"task\": \"w001-t1\", \"outcome\": \"stuck\", \"reason\": \"stuck\", \"time\": 31}}]}}}}"
    );
    let file = dir.join("episodes.json");
    std::fs::write(&file, reference).unwrap();
    let out = vb(&["sim", "episodes", "--reference", file.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        text.contains("pid driving 2 tasks under the paper rules"),
        "{text}"
    );
    assert!(
        text.contains("w001-t0") && text.contains("w001-t1"),
        "{text}"
    );
    assert!(text.contains("of 2 tasks; ours / Chrono 10.0.0:"), "{text}");
    let none = dir.join("none.json");
    std::fs::write(&none, "{\"datasheets\": []}").unwrap();
    let out = vb(&["sim", "episodes", "--reference", none.to_str().unwrap()]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("holds no episodes"));
    let _ = std::fs::remove_dir_all(&dir);
}
