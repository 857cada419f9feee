//! `vb-submit` as a user runs it: clear errors without a token or a coordinator, and `validate` on good and broken
//! planners (the example planner, started as a separate process through the worker's code path).

use std::path::{Path, PathBuf};
use std::process::Command;

fn vb_submit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_vb-submit"));
    c.env_remove("VB_TOKEN")
        .env_remove("VB_COORDINATOR")
        .env("HOME", std::env::temp_dir());
    c
}

fn example_planner() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf();
    let bin = dir.join("example-planner");
    if !bin.exists() {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "-p", "example-planner"]);
        if dir.ends_with("release") {
            cmd.arg("--release");
        }
        assert!(
            cmd.status().unwrap().success(),
            "building the example planner failed"
        );
    }
    bin
}

fn run(c: &mut Command) -> (bool, String) {
    let out = c.output().expect("running vb-submit");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

#[test]
fn missing_token_and_unreachable_coordinator_are_explained() {
    let (ok, text) = run(vb_submit().args(["status"]));
    assert!(!ok);
    assert!(
        text.contains("no token") && text.contains("vb admin token create"),
        "{text}"
    );
    let (ok, text) = run(vb_submit().args([
        "--token",
        "x",
        "--coordinator",
        "http://127.0.0.1:9",
        "status",
    ]));
    assert!(!ok);
    assert!(
        text.contains("cannot reach the coordinator at http://127.0.0.1:9"),
        "{text}"
    );
    let (ok, text) = run(vb_submit().args(["--token", "x", "results", "sub-1", "--format", "xml"]));
    assert!(!ok && text.contains("xml"), "{text}");
}

#[test]
fn validate_accepts_a_good_planner_and_names_what_is_wrong_with_bad_ones() {
    let planner = example_planner().display().to_string();
    let (ok, text) = run(vb_submit().args(["validate", "exec", "--max-time", "5", "--", &planner]));
    assert!(ok, "{text}");
    assert!(
        text.contains("OK: the planner follows the protocol"),
        "{text}"
    );
    assert!(
        text.contains("control steps") && text.contains("round trip p50"),
        "{text}"
    );
    assert!(
        text.contains("example-planner: episode w001-t0 started") || text.contains("ready for"),
        "the planner's log is shown: {text}"
    );

    let (ok, text) = run(vb_submit().args([
        "validate",
        "exec",
        "--max-time",
        "5",
        "--",
        &planner,
        "--fault",
        "nan",
    ]));
    assert!(!ok);
    assert!(
        text.contains("invalid_action") && text.contains("not finite"),
        "{text}"
    );

    let (ok, text) = run(vb_submit().args([
        "validate",
        "exec",
        "--max-time",
        "5",
        "--step-deadline",
        "0.2",
        "--",
        &planner,
        "--fault",
        "hang",
    ]));
    assert!(!ok);
    assert!(text.contains("planner_timeout"), "{text}");

    let (ok, text) = run(vb_submit().args(["validate", "exec", "--", "/nonexistent/planner"]));
    assert!(!ok);
    assert!(
        text.contains("cannot start planner `/nonexistent/planner`"),
        "{text}"
    );

    let (ok, text) = run(vb_submit().args(["validate", "endpoint", "http://127.0.0.1:9"]));
    assert!(!ok);
    assert!(
        text.contains("planner_unreachable") && text.contains("cannot connect"),
        "{text}"
    );
}
