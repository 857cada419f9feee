//! `vb-submit` as a user runs it: clear errors without a token or a coordinator, and `validate` on good and broken
//! planners (the example planner, started as a separate process through the worker's code path).

use std::path::{Path, PathBuf};
use std::process::Command;

mod containment;

fn vb_submit() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_vb-submit"));
    c.env_remove("VB_TOKEN")
        .env_remove("VB_COORDINATOR")
        .env("HOME", std::env::temp_dir());
    c
}

/// The example planner, brought up to date once per test process (it belongs to another package: `cargo test`
/// leaves it missing or stale).
fn example_planner() -> PathBuf {
    static BUILT: std::sync::Once = std::sync::Once::new();
    let exe = std::env::current_exe().unwrap();
    let dir = exe.parent().and_then(Path::parent).unwrap().to_path_buf();
    let bin = dir.join("example-planner");
    BUILT.call_once(|| {
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
    });
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

    // Under nominal the planner gets the believed map and its updates (it reports what it knows every 50 steps).
    let (ok, text) = run(vb_submit().args([
        "validate",
        "exec",
        "--max-time",
        "8",
        "--perception",
        "nominal",
        "--",
        &planner,
    ]));
    assert!(ok && text.contains("believed map:"), "{text}");
    let (ok, text) =
        run(vb_submit().args(["validate", "exec", "--perception", "foggy", "--", &planner]));
    assert!(
        !ok && text.contains("unknown perception profile `foggy`"),
        "{text}"
    );

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

#[test]
fn user_errors_are_one_line_without_a_backtrace_and_a_closed_pipe_is_quiet() {
    let out = vb_submit()
        .env("RUST_BACKTRACE", "1")
        .args([
            "--token",
            "x",
            "--coordinator",
            "http://127.0.0.1:9",
            "builtin",
            "pid",
            "--tasks",
            " , ",
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(err.starts_with("error: --tasks is empty"), "{err}");
    assert!(
        !err.contains("backtrace") && !err.contains("Backtrace"),
        "{err}"
    );
    // Printing into a pipe the reader closed ends the program quietly (SIGPIPE), not with a panic.
    let mut child = vb_submit()
        .args(["--help"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn a_planner_script_given_by_a_relative_path_is_found() {
    // Workers start planners in a private directory: vb-submit makes `planner.sh` absolute first.
    let dir = std::env::temp_dir().join(format!("vb-relative-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let planner = example_planner().display().to_string();
    std::fs::write(dir.join("planner.sh"), format!("exec {planner}\n")).unwrap();
    let (ok, text) = run(vb_submit().current_dir(&dir).args([
        "validate",
        "exec",
        "--max-time",
        "2",
        "--",
        "sh",
        "planner.sh",
    ]));
    assert!(ok, "{text}");
    assert_eq!(
        vb_submit::absolute_paths(&["sh".into(), "-c".into(), "nonexistent.sh".into()]),
        ["sh", "-c", "nonexistent.sh"]
    );
}
