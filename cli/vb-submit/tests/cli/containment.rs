//! Exec planners are contained: their children, files, processes and output end with them, under resource limits,
//! and they may run as an unprivileged user.

use std::path::{Path, PathBuf};
use std::process::Command;

use super::{example_planner, run, vb_submit};

/// Waits up to `secs` for `pred`.
fn eventually(secs: f64, pred: impl Fn() -> bool) -> bool {
    let t0 = std::time::Instant::now();
    while t0.elapsed().as_secs_f64() < secs {
        if pred() {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    pred()
}

/// `vb-submit validate exec` of a `sh -c` script, 2 simulated seconds.
fn validate_script(script: &str) -> (bool, String) {
    validate_script_as(&mut vb_submit(), None, script)
}

/// [`validate_script`] with `c`'s arguments and environment, the planner run as `user` when given.
fn validate_script_as(c: &mut Command, user: Option<&str>, script: &str) -> (bool, String) {
    c.args(["validate", "exec", "--max-time", "2"]);
    if let Some(user) = user {
        c.args(["--planner-user", user]);
    }
    run(c.args(["--", "sh", "-c", script]))
}

/// Whether process `pid` has ended (gone, or a zombie waiting for its parent).
fn gone(pid: &str) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .map(|s| s.contains(") Z"))
        .unwrap_or(true)
}

/// The value after `key` on the line of the planner log that has it.
fn logged<'a>(text: &'a str, key: &str) -> &'a str {
    text.lines()
        .find_map(|l| l.split_once(key).map(|(_, v)| v.trim()))
        .unwrap_or_else(|| panic!("no `{key}` in the planner log: {text}"))
}

/// Processes on this machine whose command line contains `marker` (a planner's namespace hides them from the planner,
/// not from us).
fn processes_with(marker: &str) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.bytes().all(|b| b.is_ascii_digit()) || gone(&name) {
            continue;
        }
        if let Ok(cmd) = std::fs::read(entry.path().join("cmdline")) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            if cmd.contains(marker) {
                found.push(format!("{name}: {cmd}"));
            }
        }
    }
    found
}

/// The shell lines of a planner that starts two long sleeps that escape its process group (`setsid`, and a
/// double fork into a new session) with `marker` in their command lines; the script itself never spells the marker
/// out, so only those sleeps carry it.
fn escaping_children(marker: &str) -> String {
    let (head, tail) = marker.split_at(3);
    format!("m={head}; setsid sleep \"${{m}}{tail}\" & (setsid sh -c \"sleep ${{m}}{tail}\" &); ")
}

#[test]
fn exec_planners_run_contained_and_leave_nothing_behind() {
    let planner = example_planner().display().to_string();
    let marker = format!("4000.{}", std::process::id());
    let file = format!("vb-marker-{}", std::process::id());
    // The planner reports its environment and directory, starts children that escape its process group, counts
    // the processes it can see, leaves files in every temporary directory, then serves.
    let script = format!(
        "echo \"ENV: $(env | cut -d= -f1 | sort | tr '\\n' ' ')\"; echo \"DIR: $PWD\"; \
         echo \"HOME: $HOME\"; {}sleep 0.2; echo \"PROCS: $(ls -d /proc/[0-9]* | wc -l)\"; \
         for d in /tmp /var/tmp /dev/shm; do echo x > $d/{file} && echo \"WROTE: $d\"; done; \
         exec {planner}",
        escaping_children(&marker)
    );
    let (ok, text) = run(vb_submit().env("VB_SECRET_TOKEN", "hunter2").args([
        "validate",
        "exec",
        "--max-time",
        "3",
        "--",
        "sh",
        "-c",
        &script,
    ]));
    assert!(ok, "{text}");
    let env = logged(&text, "ENV:");
    assert!(
        !env.contains("VB_SECRET_TOKEN"),
        "the worker's environment leaked: {env}"
    );
    for var in env.split_whitespace() {
        assert!(
            [
                "PATH",
                "HOME",
                "TMPDIR",
                "LANG",
                "VB_PLANNER_ADDR",
                "PWD",
                "SHLVL",
                "OLDPWD",
                "_"
            ]
            .contains(&var),
            "unexpected variable {var} in {env}"
        );
    }
    let dir = logged(&text, "DIR:");
    assert_eq!(logged(&text, "HOME:"), dir, "HOME is the private directory");
    if text.contains("ran without namespaces") {
        // A machine without namespaces (a worker there refuses exec planners): the private directory still goes.
        eprintln!("SKIPPED: the namespace checks (this machine gives planners none): {text}");
        assert!(dir.contains("vb-planner-"), "{dir}");
        assert!(
            eventually(5.0, || !Path::new(dir).exists()),
            "the private directory {dir} is removed after the episode"
        );
        return;
    }
    assert_eq!(dir, "/tmp", "the planner works in its own /tmp");
    let procs: usize = logged(&text, "PROCS:").parse().unwrap();
    assert!(
        (3..=8).contains(&procs),
        "the planner sees {procs} processes: its shell and its two sleeps, with the shell's own helpers, only"
    );
    assert_eq!(
        text.matches("WROTE:").count(),
        3,
        "the planner could write its temporary directories: {text}"
    );
    for d in ["/tmp", "/var/tmp", "/dev/shm"] {
        let path = Path::new(d).join(&file);
        assert!(!path.exists(), "{} outlived the planner", path.display());
    }
    assert!(
        eventually(5.0, || processes_with(&marker).is_empty()),
        "children that escaped the planner's process group outlived its episode: {:?}",
        processes_with(&marker)
    );
}

#[test]
fn a_planner_flooding_its_output_gets_a_bounded_log() {
    let planner = example_planner().display().to_string();
    // 64 MB without a newline, then a normal line.
    let script = format!(
        "head -c 67108864 /dev/zero | tr '\\000' x; echo; echo after the flood; exec {planner}"
    );
    let (ok, text) = validate_script(&script);
    assert!(ok, "{text}");
    assert!(
        text.contains("[line cut at 4096 bytes]"),
        "{}",
        &text[..text.len().min(2000)]
    );
    assert!(
        text.contains("after the flood"),
        "lines after a cut one are kept"
    );
    assert!(
        text.len() < 200_000,
        "the log is bounded: {} bytes",
        text.len()
    );
}

#[test]
fn exec_planners_run_under_resource_limits_and_die_with_their_worker() {
    let planner = example_planner().display().to_string();
    let script = format!("echo \"LIMITS: $(ulimit -n) $(ulimit -t) $(ulimit -v)\"; exec {planner}");
    let (ok, text) = validate_script(&script);
    assert!(ok, "{text}");
    let limits: Vec<&str> = logged(&text, "LIMITS:").split_whitespace().collect();
    // Open files, CPU seconds and address space (KiB) of `vb_worker::sandbox::Limits::default()`.
    assert_eq!(
        limits,
        ["1024", "3600", &(16u64 << 20).to_string()],
        "{text}"
    );

    // The worker (here vb-submit's validate) is killed with SIGKILL while its planner runs: the planner dies too,
    // and so do the children it started in sessions of their own.
    let marker = format!("4100.{}", std::process::id());
    let script = format!(
        "{}sleep 1; exec {planner} --delay-ms 50",
        escaping_children(&marker)
    );
    let mut child = vb_submit()
        .args([
            "validate",
            "exec",
            "--max-time",
            "60",
            "--",
            "sh",
            "-c",
            &script,
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    assert!(
        eventually(30.0, || processes_with(&marker).len() >= 2),
        "the planner started its children: {:?}",
        processes_with(&marker)
    );
    std::thread::sleep(std::time::Duration::from_millis(1500));
    child.kill().unwrap();
    let out = child.wait_with_output().unwrap();
    let isolated = !String::from_utf8_lossy(&out.stderr).contains("ran without namespaces");
    if isolated {
        assert!(
            eventually(5.0, || processes_with(&marker).is_empty()),
            "the planner's children outlived its killed worker: {:?}",
            processes_with(&marker)
        );
    } else {
        eprintln!("SKIPPED: escaped children outliving a killed worker (this machine gives planners no namespaces)");
    }
}

#[test]
fn a_planner_scanning_proc_finds_no_other_process_s_secrets() {
    // Issue 35: a planner running as nobody read `vb worker --token ...` off /proc/*/cmdline. Here vb-submit is the
    // worker, with a token on its command line and one in its environment.
    if !nix_is_root() {
        eprintln!("SKIPPED: running exec planners as another user needs root");
        return;
    }
    let planner = nobody_planner("scan");
    let secret = format!("s3cret-{}", std::process::id());
    let (head, tail) = secret.split_at(3);
    let script = format!(
        "p={head}; n=0; for f in /proc/[0-9]*/cmdline /proc/[0-9]*/environ; do \
         grep -q \"${{p}}{tail}\" $f 2>/dev/null && n=$((n+1)); done; echo \"FOUND: $n\"; exec {}",
        planner.display()
    );
    let (ok, text) = validate_script_as(
        vb_submit()
            .env("VB_TOKEN", &secret)
            .args(["--token", &secret]),
        Some("nobody"),
        &script,
    );
    assert!(ok, "{text}");
    if text.contains("ran without namespaces") {
        eprintln!("SKIPPED: the /proc scan (this machine gives planners no namespaces)");
        return;
    }
    assert_eq!(logged(&text, "FOUND:"), "0", "{text}");
}

/// A copy of the example planner that `nobody` can run (the build directory may be private), outside the temporary
/// directories (a planner has its own).
fn nobody_planner(name: &str) -> PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let base = Path::new("/var/lib/vertibench-tests");
    let dir = base.join(format!("{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::set_permissions(base, std::fs::Permissions::from_mode(0o755)).unwrap();
    let planner = dir.join("example-planner");
    std::fs::copy(example_planner(), &planner).unwrap();
    std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::set_permissions(&planner, std::fs::Permissions::from_mode(0o755)).unwrap();
    planner
}

#[test]
fn exec_planners_can_run_as_an_unprivileged_user() {
    if !nix_is_root() {
        eprintln!("SKIPPED: running exec planners as another user needs root");
        return;
    }
    // The planner binary must be reachable by `nobody`: a copy in a world-readable directory.
    let planner = nobody_planner("user");
    let dir = planner.parent().unwrap();
    use std::os::unix::fs::PermissionsExt;
    let secret = dir.join("worker-secret");
    std::fs::write(&secret, "hunter2").unwrap();
    std::fs::set_permissions(&secret, std::fs::Permissions::from_mode(0o600)).unwrap();
    let script = format!(
        "echo \"UID: $(id -u)\"; cat {} >/dev/null 2>&1 && echo 'READ: yes' || echo 'READ: no'; exec {}",
        secret.display(),
        planner.display()
    );
    let (ok, text) = validate_script_as(&mut vb_submit(), Some("nobody"), &script);
    assert!(ok, "{text}");
    assert_ne!(logged(&text, "UID:"), "0", "{text}");
    assert_eq!(
        logged(&text, "READ:"),
        "no",
        "the planner read the worker's file: {text}"
    );
    let (ok, text) = run(vb_submit().args([
        "validate",
        "exec",
        "--planner-user",
        "no-such-user-here",
        "--",
        "true",
    ]));
    assert!(
        !ok && text.contains("no user `no-such-user-here`"),
        "{text}"
    );
}

fn nix_is_root() -> bool {
    std::fs::read_to_string("/proc/self/status")
        .map(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(1))
                == Some("0")
        })
        .unwrap_or(false)
}
