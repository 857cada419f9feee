//! Issue 35 over real processes: no server dies of a peer that closes its connection, and a planner and everything
//! it starts die with its episode and with its worker, without seeing the worker's token.

use integration::*;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};
use vb_proto::v1 as pb;

/// The 50 bytes that killed every server: the HTTP/2 preface, an empty SETTINGS frame and a PING, then close (the
/// server's answer then meets a closed socket: EPIPE, and SIGPIPE where it is not ignored).
const PROBE: [u8; 50] = {
    let mut p = [0u8; 50];
    let preface = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";
    let mut i = 0;
    while i < preface.len() {
        p[i] = preface[i];
        i += 1;
    }
    // SETTINGS: length 0, type 4, no flags, stream 0.
    p[27] = 4;
    // PING: length 8, type 6, no flags, stream 0, eight bytes of payload.
    p[35] = 8;
    p[36] = 6;
    let mut j = 41;
    while j < 50 {
        p[j] = j as u8;
        j += 1;
    }
    p
};

/// Sends the probe `n` times, closing at once or after reading a little of the answer (both ways of closing early).
fn probe(port: u16, n: usize) {
    for i in 0..n {
        if let Ok(mut s) = TcpStream::connect(("127.0.0.1", port)) {
            let _ = s.write_all(&PROBE);
            if i % 2 == 1 {
                let _ = s.set_read_timeout(Some(Duration::from_millis(200)));
                let _ = s.read(&mut [0u8; 16]);
            }
        }
    }
}

/// Whether process `pid` ignores SIGPIPE (its `SigIgn` mask in /proc has bit 13).
fn ignores_sigpipe(pid: u32) -> bool {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigIgn:"))
        .and_then(|m| u64::from_str_radix(m.trim(), 16).ok())
        .is_some_and(|m| m & (1 << 12) != 0)
}

fn alive(p: &mut Proc) -> bool {
    matches!(p.child.try_wait(), Ok(None))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn no_server_dies_of_a_peer_that_closes_its_connection() -> anyhow::Result<()> {
    let dir = temp_dir("sigpipe");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let mut coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let http = free_port();
    let mut leaderboard = Proc::start(
        "leaderboard",
        &dir,
        &vb(),
        &[
            "leaderboard",
            "--db",
            &db,
            "--listen",
            &format!("127.0.0.1:{http}"),
        ],
    );
    let serve_db = format!("sqlite://{}", dir.join("serve.db").display());
    let (serve_grpc, serve_http) = (free_port(), free_port());
    let mut serve = Proc::start(
        "serve",
        &dir,
        &vb(),
        &[
            "serve",
            "--db",
            &serve_db,
            "--grpc",
            &format!("127.0.0.1:{serve_grpc}"),
            "--http",
            &format!("127.0.0.1:{serve_http}"),
            "--slots",
            "1",
        ],
    );
    for p in [port, http, serve_grpc, serve_http] {
        wait_port(p, Duration::from_secs(60));
    }
    for p in [port, http, serve_grpc, serve_http] {
        probe(p, 40);
    }
    for p in [&mut coordinator, &mut leaderboard, &mut serve] {
        assert!(
            alive(p),
            "{} died of closed connections: {}",
            p.name,
            p.output()
        );
        assert!(
            ignores_sigpipe(p.child.id()),
            "{} does not ignore SIGPIPE",
            p.name
        );
    }
    // Still answering.
    let mut c = client(port, &token).await;
    vb_submit::list(&mut c).await?;
    assert!(http_text(http, "/").contains("<html"));
    assert!(http_text(serve_http, "/").contains("<html"));
    vb_submit::connect(&format!("http://127.0.0.1:{serve_grpc}"), "x", None).await?;
    Ok(())
}

/// A planner endpoint that accepts every connection, reads a little and closes it.
fn closing_endpoint() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    let port = listener.local_addr().expect("its address").port();
    std::thread::spawn(move || {
        for s in listener.incoming().flatten() {
            let mut s = s;
            let _ = s.set_read_timeout(Some(Duration::from_millis(100)));
            let _ = s.read(&mut [0u8; 64]);
            drop(s);
        }
    });
    port
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_outlives_endpoint_planners_that_close_early() -> anyhow::Result<()> {
    let dir = temp_dir("early-close");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let mut worker = start_worker(&dir, "worker", &db, port, 2);
    let mut c = client(port, &token).await;
    let endpoint = closing_endpoint();
    let sub = vb_submit::submit(
        &mut c,
        pb::SubmitRequest {
            step_deadline_s: 1.0,
            ..endpoint_submission(
                "closes early",
                &format!("http://127.0.0.1:{endpoint}"),
                &["1", "2"],
            )
        },
    )
    .await?;
    let s = wait_for(
        port,
        &token,
        &sub.submission_id,
        Duration::from_secs(180),
        |s| s.state() == pb::SubmissionState::Done,
    )
    .await;
    assert_eq!((s.finished, s.total), (20, 20));
    let r = vb_submit::results(&mut c, &sub.submission_id).await?;
    for e in &r.episodes {
        assert_eq!(e.outcome(), pb::Outcome::PlannerFailure, "{e:?}");
    }
    assert!(alive(&mut worker), "the worker died: {}", worker.output());
    assert!(ignores_sigpipe(worker.child.id()));
    Ok(())
}

/// Host processes whose command line contains `marker`.
fn processes_with(marker: &str) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if !name.bytes().all(|b| b.is_ascii_digit()) {
            continue;
        }
        let zombie = std::fs::read_to_string(entry.path().join("stat"))
            .map(|s| s.contains(") Z"))
            .unwrap_or(true);
        if let (false, Ok(cmd)) = (zombie, std::fs::read(entry.path().join("cmdline"))) {
            let cmd = String::from_utf8_lossy(&cmd).replace('\0', " ");
            if cmd.contains(marker) {
                found.push(format!("{name}: {cmd}"));
            }
        }
    }
    found
}

fn eventually(limit: Duration, pred: impl Fn() -> bool) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < limit {
        if pred() {
            return true;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    pred()
}

fn exec_submission(name: &str, tasks: &[&str], script: String) -> pb::SubmitRequest {
    exec_argv_submission(name, tasks, vec!["sh".into(), "-c".into(), script])
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_s_escaped_children_die_with_its_killed_worker() -> anyhow::Result<()> {
    if !namespaces_available(None).await {
        return Ok(());
    }
    let dir = temp_dir("worker-kill");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let mut worker = start_worker(&dir, "worker", &db, port, 1);
    let marker = format!("4200.{}", std::process::id());
    let (head, tail) = marker.split_at(3);
    // Children in sessions of their own (setsid, and a double fork), then a slow planner.
    let script = format!(
        "m={head}; setsid sleep \"${{m}}{tail}\" & (setsid sh -c \"sleep ${{m}}{tail}\" &); \
         exec {} --delay-ms 20",
        example_planner().display()
    );
    let mut c = client(port, &token).await;
    vb_submit::submit(&mut c, exec_submission("escapes", &["1"], script)).await?;
    assert!(
        eventually(Duration::from_secs(60), || processes_with(&marker).len()
            >= 2),
        "the planner started its children: {}",
        worker.output()
    );
    worker.kill();
    assert!(
        eventually(Duration::from_secs(5), || processes_with(&marker)
            .is_empty()),
        "the planner's children outlived its worker's SIGKILL: {:?}",
        processes_with(&marker)
    );
    // No directory to leave behind: the planner's working directory is its own tmpfs (tests/cli.rs in vb-submit).
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_finds_no_token_in_proc_and_its_log_is_its_owner_s() -> anyhow::Result<()> {
    let root = std::fs::read_to_string("/proc/self/status")
        .is_ok_and(|s| s.lines().any(|l| l.starts_with("Uid:\t0\t")));
    if !root {
        eprintln!("SKIPPED: running planners as nobody needs root");
        return Ok(());
    }
    if !namespaces_available(Some("nobody")).await {
        return Ok(());
    }
    let dir = temp_dir("proc-scan");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker_with(&dir, "worker", &db, port, 1, &["--planner-user", "nobody"]);
    // The planner binary where nobody can run it, outside the temporary directories (the planner has its own).
    use std::os::unix::fs::PermissionsExt;
    let shared = std::path::Path::new("/var/lib/vertibench-tests");
    let planner_dir = shared.join(format!("scan-{}", std::process::id()));
    std::fs::create_dir_all(&planner_dir)?;
    for d in [shared, planner_dir.as_path()] {
        std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o755))?;
    }
    let planner = planner_dir.join("example-planner");
    std::fs::copy(example_planner(), &planner)?;
    // A process on the host with a secret on its command line (as `vb worker --token` had), and the worker's token
    // in the worker's environment: the planner scans every command line and environment it can read for both.
    let secret = format!("vbsecret-{}", std::process::id());
    let mut decoy = std::process::Command::new("sh")
        .args(["-c", "sleep 600; :", &secret])
        .stdout(std::process::Stdio::null())
        .spawn()?;
    let (head, tail) = secret.split_at(4);
    let script = format!(
        "p={head}; n=0; for f in /proc/[0-9]*/cmdline /proc/[0-9]*/environ; do \
         grep -q -e \"${{p}}{tail}\" -e \"VB_WORKER_\"\"TOKEN\" $f 2>/dev/null && n=$((n+1)); done; \
         echo \"FOUND: $n\"; echo \"PROCS: $(ls -d /proc/[0-9]* | wc -l)\"; exec {}",
        planner.display()
    );
    let mut c = client(port, &token).await;
    let sub = vb_submit::submit(&mut c, exec_submission("scan", &["w001-t0"], script)).await?;
    wait_for(
        port,
        &token,
        &sub.submission_id,
        Duration::from_secs(120),
        |s| s.state() == pb::SubmissionState::Done,
    )
    .await;
    let _ = decoy.kill();
    let _ = decoy.wait();
    let log =
        vb_submit::episode_log(&mut c, &sub.submission_id, contracts::TaskId::new(1, 0)).await?;
    assert!(log.contains("FOUND: 0"), "{log}");
    let procs: usize = log
        .lines()
        .find_map(|l| l.strip_prefix("PROCS: "))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or(usize::MAX);
    assert!(procs <= 4, "the planner sees {procs} processes: {log}");
    // The owner's results directory holds it too.
    let out = dir.join("results");
    let done = std::process::Command::new(vb_submit_bin())
        .env("VB_TOKEN", &token)
        .args([
            "--coordinator",
            &format!("http://127.0.0.1:{port}"),
            "results",
        ])
        .arg(&sub.submission_id)
        .arg("--out")
        .arg(&out)
        .arg("--logs")
        .output()?;
    assert!(
        done.status.success(),
        "{}",
        String::from_utf8_lossy(&done.stderr)
    );
    let saved = std::fs::read_to_string(out.join("logs").join("w001-t0.log"))?;
    assert_eq!(saved, log);
    // Another user may not read it.
    let other = create_token_with_role(&db, "mallory", "user");
    let mut m = client(port, &other).await;
    let err = vb_submit::episode_log(&mut m, &sub.submission_id, contracts::TaskId::new(1, 0))
        .await
        .expect_err("another user read the log");
    assert!(err.to_string().contains("no submission"), "{err}");
    let _ = std::fs::remove_dir_all(&planner_dir);
    Ok(())
}

/// Runs `vb-submit ARGS --coordinator URL --token t` with `env`: its exit code and stderr.
fn vb_submit_at(url: &str, args: &[&str], env: &[(&str, &str)]) -> (Option<i32>, String) {
    let out = std::process::Command::new(vb_submit_bin())
        .args(args)
        .args(["--coordinator", url, "--token", "t"])
        .envs(env.iter().copied())
        .output()
        .expect("vb-submit");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A server that accepts connections and never says anything: every `vb-submit` call ends with a clear error
/// within its limits (the connection's 10 s, the call's `VB_SUBMIT_RPC_TIMEOUT_S`), never a hang.
#[test]
fn vb_submit_gives_up_on_a_silent_server() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    let port = listener.local_addr().expect("addr").port();
    std::thread::spawn(move || {
        let mut held = Vec::new();
        for s in listener.incoming().flatten() {
            held.push(s);
        }
    });
    let url = format!("http://127.0.0.1:{port}");
    vb_submit_bin(); // built before the clock starts
    for args in [&["status", "s-1"][..], &["status"][..]] {
        let started = std::time::Instant::now();
        let (code, err) = vb_submit_at(&url, args, &[("VB_SUBMIT_RPC_TIMEOUT_S", "2")]);
        assert_eq!(code, Some(1), "{args:?}: {err}");
        assert!(
            err.contains("no answer from the coordinator within 2 s")
                || err.contains("no connection within 10 s"),
            "{args:?}: {err}"
        );
        assert!(
            started.elapsed() < Duration::from_secs(30),
            "{args:?} took {:?}",
            started.elapsed()
        );
    }
}

/// Issue 58, point 6: against a server that accepts and closes every connection at once, `vb-submit` fails with a
/// message every time (it exited 141, silently, by SIGPIPE in 6 of 10 tries).
#[test]
fn vb_submit_says_why_when_the_server_closes_at_once() {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("a port");
    let port = listener.local_addr().expect("addr").port();
    std::thread::spawn(move || {
        for s in listener.incoming().flatten() {
            drop(s);
        }
    });
    let url = format!("http://127.0.0.1:{port}");
    for args in [
        &["status", "s-1"][..],
        &["status"][..],
        &["endpoint", "http://127.0.0.1:9/x", "--tasks", "w000-t0"][..],
    ] {
        for _ in 0..4 {
            // A call can wait for an answer on a connection tonic has not seen closed (it hung here once, with no
            // limit): the limit makes that an error too, in 5 s.
            let (code, err) = vb_submit_at(&url, args, &[("VB_SUBMIT_RPC_TIMEOUT_S", "5")]);
            assert_eq!(code, Some(1), "{args:?}: {err}");
            assert!(err.contains("error:"), "{args:?}: no message: {err}");
        }
    }
}
