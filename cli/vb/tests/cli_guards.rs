//! `vb` refuses what would destroy data by accident, and stops cleanly when told to.

#[test]
fn tasks_generate_needs_an_output_directory() {
    // Without --out it used to overwrite the benchmark's committed task set.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
        .args(["tasks", "generate"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--out"), "{err}");
}

#[test]
fn a_worker_with_an_empty_token_says_so_instead_of_retrying_forever() {
    // As a compose file passes an unset variable: present but empty.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
        .args(["worker", "--coordinator", "http://127.0.0.1:9"])
        .env("VB_WORKER_TOKEN", "")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("worker token") && err.contains("--role worker"),
        "{err}"
    );
}

#[test]
fn a_worker_refuses_its_token_on_the_command_line_and_reads_it_from_a_file() {
    // Issue 35: a planner read `vb worker --token ...` from /proc/*/cmdline.
    let vb = env!("CARGO_BIN_EXE_vb");
    let out = std::process::Command::new(vb)
        .args([
            "worker",
            "--coordinator",
            "http://127.0.0.1:9",
            "--token",
            "s3cret",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("VB_WORKER_TOKEN") && err.contains("--token-file") && err.contains("/proc"),
        "{err}"
    );
    assert!(
        !err.contains("s3cret"),
        "the refusal repeats the secret: {err}"
    );
    // A file that is missing or holds nothing is named in the error.
    let dir = std::env::temp_dir().join(format!("vb-token-file-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("missing");
    let out = std::process::Command::new(vb)
        .args([
            "worker",
            "--coordinator",
            "http://127.0.0.1:9",
            "--token-file",
        ])
        .arg(&missing)
        .env_remove("VB_WORKER_TOKEN")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains(&*missing.to_string_lossy()),
        "{err}"
    );
    let empty = dir.join("empty");
    std::fs::write(&empty, "\n").unwrap();
    let out = std::process::Command::new(vb)
        .args([
            "worker",
            "--coordinator",
            "http://127.0.0.1:9",
            "--token-file",
        ])
        .arg(&empty)
        .env("VB_WORKER_TOKEN", "ignored-when-a-file-is-given")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("no worker token"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn admin_token_create_without_a_store_here_explains_instead_of_making_one() {
    let dir = std::env::temp_dir().join(format!("vb-admin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
        .args(["admin", "token", "create", "--name", "alice"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no store at out/vb.db") && err.contains("--db"),
        "{err}"
    );
    assert!(!dir.join("out").exists(), "no empty store was made");
}

/// `vb serve` (with `--evaluate` running an evaluation, or idle) exits cleanly on SIGTERM, also when the signal comes
/// the moment its leaderboard port opens (its handler is installed before anything binds).
#[test]
fn vb_serve_stops_cleanly_on_sigterm() {
    for (k, evaluate) in [&[][..], &["--evaluate", "pid"][..]]
        .into_iter()
        .enumerate()
    {
        let dir = std::env::temp_dir().join(format!("vb-sigterm-{}-{k}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (grpc, http) = (integration::free_port(), integration::free_port());
        let db = format!("sqlite://{}/vb.db", dir.display());
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
            .args(["serve", "--db", &db, "--slots", "1"])
            .args([
                "--grpc",
                &format!("127.0.0.1:{grpc}"),
                "--http",
                &format!("127.0.0.1:{http}"),
            ])
            .args(evaluate)
            .current_dir(&dir)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        integration::wait_port(http, std::time::Duration::from_secs(60));
        if !evaluate.is_empty() {
            // Into the evaluation (1000 episodes: far from done).
            std::thread::sleep(std::time::Duration::from_secs(2));
            assert!(
                child.try_wait().unwrap().is_none(),
                "vb serve --evaluate exited early"
            );
        }
        let pid = child.id().to_string();
        assert!(std::process::Command::new("kill")
            .args(["-TERM", &pid])
            .status()
            .unwrap()
            .success());
        let t0 = std::time::Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            assert!(
                t0.elapsed().as_secs() < 20,
                "vb serve {evaluate:?} ignored SIGTERM"
            );
            std::thread::sleep(std::time::Duration::from_millis(50));
        };
        assert!(status.success(), "vb serve {evaluate:?}: {status}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn tasks_generate_takes_a_full_scale_height_only_for_the_swae() {
    let dir = std::env::temp_dir().join(format!("vb-full-scale-{}", std::process::id()));
    let run = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
            .args(["tasks", "generate", "--out"])
            .arg(&dir)
            .args(args)
            .output()
            .unwrap()
    };
    let out = run(&["--generator", "interim", "--full-scale", "10"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--full-scale only applies to --generator swae"),
        "{err}"
    );
    let out = run(&["--generator", "swae", "--full-scale=-3"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("full_scale") && err.contains("positive"),
        "{err}"
    );
    assert!(!dir.exists(), "nothing written for refused options");
    // Accepted with the default generator (the SWAE), and named in the set's generator (so its version differs
    // from the calibrated set's).
    let out = run(&["--full-scale", "20"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("full_scale=20"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}
