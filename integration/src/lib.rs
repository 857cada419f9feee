//! Helpers of the end-to-end tests: real processes (`vb coordinator`, `vb worker`, `vb leaderboard`, the example
//! planner), real gRPC, a real database. The tests are this crate's `tests/`; `cli/vb`'s own CLI tests use the
//! helpers too.

#![allow(dead_code)]

use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant, SystemTime};

/// The `vb` binary.
pub fn vb() -> PathBuf {
    static FRESH: OnceLock<PathBuf> = OnceLock::new();
    FRESH
        .get_or_init(|| workspace_bin("vb", &["-p", "vb", "--bin", "vb"]))
        .clone()
}

/// The `vb-submit` binary, with the `validate` feature (which `vb` turns on in the workspace's build).
pub fn vb_submit_bin() -> PathBuf {
    static FRESH: OnceLock<PathBuf> = OnceLock::new();
    FRESH
        .get_or_init(|| {
            workspace_bin(
                "vb-submit",
                &[
                    "-p",
                    "vb-submit",
                    "--bin",
                    "vb-submit",
                    "--features",
                    "validate",
                ],
            )
        })
        .clone()
}

/// The example planner's binary (nothing else builds it, so it is brought up to date once per test process).
pub fn example_planner() -> PathBuf {
    static BUILT: std::sync::Once = std::sync::Once::new();
    let path = target_dir().join("example-planner");
    BUILT.call_once(|| cargo_build(&["-p", "example-planner", "--bin", "example-planner"]));
    path
}

/// A binary of this workspace at this test's profile. `cargo test --workspace` (the README's command) builds `vb`
/// and `vb-submit` fresh for their packages' own CLI tests before any test runs; run on its own (`cargo test -p
/// integration`), a binary that is missing, or older than a source file its dep-info (`NAME.d`, which cargo
/// writes beside it) lists, is built first with `cargo build ARGS`, so no test runs a stale binary.
fn workspace_bin(name: &str, build: &[&str]) -> PathBuf {
    let path = target_dir().join(name);
    if !is_fresh(&path) {
        cargo_build(build);
    }
    assert!(
        is_fresh(&path),
        "cargo build {build:?} left {} stale",
        path.display()
    );
    path
}

fn is_fresh(binary: &Path) -> bool {
    let built = match std::fs::metadata(binary).and_then(|m| m.modified()) {
        Ok(t) => t,
        Err(_) => return false,
    };
    let Ok(deps) = std::fs::read_to_string(binary.with_extension("d")) else {
        return false;
    };
    // "TARGET: SOURCE SOURCE ...", spaces in paths escaped with a backslash.
    let Some((_, sources)) = deps.split_once(": ") else {
        return false;
    };
    let mut newest = SystemTime::UNIX_EPOCH;
    for source in sources.replace("\\ ", "\u{0}").split_whitespace() {
        let source = source.replace('\u{0}', " ");
        match std::fs::metadata(&source).and_then(|m| m.modified()) {
            Ok(t) => newest = newest.max(t),
            Err(_) => return false,
        }
    }
    newest <= built
}

/// The directory of this test's profile (`target/debug`).
fn target_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("test executable path");
    exe.parent()
        .and_then(Path::parent)
        .expect("target dir")
        .to_path_buf()
}

/// `cargo build ARGS` with this test's profile.
fn cargo_build(args: &[&str]) {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.arg("build").args(args);
    if target_dir().ends_with("release") {
        cmd.arg("--release");
    }
    let st = cmd
        .status()
        .unwrap_or_else(|e| panic!("running cargo build {args:?}: {e}"));
    assert!(st.success(), "cargo build {args:?} failed");
}

pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port")
}

/// A child process killed when dropped; its output goes to a log file.
pub struct Proc {
    pub child: Child,
    pub name: String,
    pub log: PathBuf,
}

impl Proc {
    pub fn start(name: &str, dir: &Path, program: &Path, args: &[&str]) -> Proc {
        Proc::start_env(name, dir, program, args, &[])
    }

    /// [`Proc::start`] with environment variables `env` set.
    pub fn start_env(
        name: &str,
        dir: &Path,
        program: &Path,
        args: &[&str],
        env: &[(&str, &str)],
    ) -> Proc {
        let log = dir.join(format!("{name}.log"));
        let out = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .expect("log file");
        let child = Command::new(program)
            .args(args)
            .envs(env.iter().copied())
            .stdout(out.try_clone().expect("log file"))
            .stderr(out)
            .stdin(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| panic!("starting {name}: {e}"));
        Proc {
            child,
            name: name.into(),
            log,
        }
    }

    /// SIGKILL: the process gets no chance to clean up.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }

    /// SIGTERM, then waits up to `limit` for the process to exit; whether it did.
    pub fn terminate(&mut self, limit: Duration) -> bool {
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let t0 = Instant::now();
        while t0.elapsed() < limit {
            if let Ok(Some(_)) = self.child.try_wait() {
                return true;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        false
    }

    pub fn output(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        self.kill();
    }
}

pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vb-e2e-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}

/// Runs `vb args...` to completion and returns stdout.
pub fn vb_run(args: &[&str]) -> String {
    let out = Command::new(vb()).args(args).output().expect("running vb");
    assert!(
        out.status.success(),
        "vb {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub fn create_token(db: &str) -> String {
    create_token_with_role(db, "tester", "user")
}

pub fn create_token_with_role(db: &str, name: &str, role: &str) -> String {
    vb_run(&[
        "admin", "token", "create", "--name", name, "--role", role, "--db", db,
    ])
    .trim()
    .to_string()
}

pub fn start_coordinator(dir: &Path, name: &str, db: &str, port: u16) -> Proc {
    start_coordinator_with(dir, name, db, port, &[])
}

/// A `vb coordinator` (3 s leases, 0.5 s heartbeats) with `extra` arguments.
pub fn start_coordinator_with(dir: &Path, name: &str, db: &str, port: u16, extra: &[&str]) -> Proc {
    let listen = format!("127.0.0.1:{port}");
    let mut args = vec![
        "coordinator",
        "--db",
        db,
        "--listen",
        &listen,
        "--lease-s",
        "3",
        "--heartbeat-s",
        "0.5",
    ];
    args.extend_from_slice(extra);
    let p = Proc::start(name, dir, &vb(), &args);
    wait_port(port, Duration::from_secs(30));
    p
}

/// A `vb leaderboard` on a free port reading the store `db`, serving; returns it and its port.
pub fn start_leaderboard(dir: &Path, db: &str) -> (Proc, u16) {
    let port = free_port();
    let listen = format!("127.0.0.1:{port}");
    let p = Proc::start(
        "leaderboard",
        dir,
        &vb(),
        &["leaderboard", "--db", db, "--listen", &listen],
    );
    wait_port(port, Duration::from_secs(30));
    (p, port)
}

/// A `vb worker` with a worker token of its own from the store `db`.
pub fn start_worker(dir: &Path, name: &str, db: &str, port: u16, slots: usize) -> Proc {
    start_worker_with(dir, name, db, port, slots, &[])
}

/// A `vb worker` with a worker token of its own from the store `db` and `extra` arguments.
pub fn start_worker_with(
    dir: &Path,
    name: &str,
    db: &str,
    port: u16,
    slots: usize,
    extra: &[&str],
) -> Proc {
    let url = format!("http://127.0.0.1:{port}");
    let slots = slots.to_string();
    let token = create_token_with_role(db, name, "worker");
    let mut args = vec![
        "worker",
        "--coordinator",
        &url,
        "--slots",
        &slots,
        "--name",
        name,
    ];
    args.extend_from_slice(extra);
    // The token never on the command line (`vb worker` refuses `--token`).
    Proc::start_env(name, dir, &vb(), &args, &[("VB_WORKER_TOKEN", &token)])
}

pub fn wait_port(port: u16, limit: Duration) {
    let t0 = Instant::now();
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            t0.elapsed() < limit,
            "nothing listens on port {port} after {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A minimal HTTP/1.1 GET: (status code, body bytes).
pub fn http_get(port: u16, path: &str) -> (u16, Vec<u8>) {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).expect("connect to leaderboard");
    s.set_read_timeout(Some(Duration::from_secs(30))).ok();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n"
    )
    .expect("send request");
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).expect("read response");
    let split = buf
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("header end");
    let head = String::from_utf8_lossy(&buf[..split]).to_string();
    let code = head
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .expect("status code");
    let mut body = buf[split + 4..].to_vec();
    if head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        body = dechunk(&body);
    }
    (code, body)
}

fn dechunk(mut b: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    while let Some(eol) = b.windows(2).position(|w| w == b"\r\n") {
        let n = usize::from_str_radix(String::from_utf8_lossy(&b[..eol]).trim(), 16).unwrap_or(0);
        let Some(chunk) = b.get(eol + 2..eol + 2 + n) else {
            break;
        };
        if n == 0 {
            break;
        }
        out.extend_from_slice(chunk);
        b = b.get(eol + 2 + n + 2..).unwrap_or_default();
    }
    out
}

pub fn http_text(port: u16, path: &str) -> String {
    let (code, body) = http_get(port, path);
    assert_eq!(code, 200, "GET {path}: {}", String::from_utf8_lossy(&body));
    String::from_utf8_lossy(&body).into_owned()
}

/// Connects to the coordinator's public API, retrying while it starts.
pub async fn client(port: u16, token: &str) -> vb_submit::Client {
    let url = format!("http://127.0.0.1:{port}");
    let t0 = Instant::now();
    loop {
        match vb_submit::connect(&url, token, None).await {
            Ok(c) => return c,
            Err(e) if t0.elapsed() > Duration::from_secs(30) => {
                panic!("coordinator not reachable: {e}")
            }
            Err(_) => tokio::time::sleep(Duration::from_millis(100)).await,
        }
    }
}

/// Polls a submission until `pred` holds (tolerating a coordinator that is down for a while).
pub async fn wait_for(
    port: u16,
    token: &str,
    id: &str,
    limit: Duration,
    pred: impl Fn(&vb_submit::SubmissionStatus) -> bool,
) -> vb_submit::SubmissionStatus {
    let t0 = Instant::now();
    loop {
        if let Ok(mut c) =
            vb_submit::connect(&format!("http://127.0.0.1:{port}"), token, None).await
        {
            if let Ok(s) = vb_submit::status(&mut c, id).await {
                if pred(&s) {
                    return s;
                }
                assert!(
                    t0.elapsed() < limit,
                    "timed out waiting on {id}: {}",
                    vb_submit::status_line(&s)
                );
            }
        }
        assert!(
            t0.elapsed() < limit,
            "timed out waiting on {id} (coordinator unreachable)"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// A CA and a server certificate for `localhost` and 127.0.0.1 signed by it (P-256 keys); None without openssl.
pub fn make_certificates(dir: &Path) -> Option<()> {
    let run = |args: &[&str]| {
        Command::new("openssl")
            .args(args)
            .current_dir(dir)
            .output()
            .map(|o| o.status.success())
            .unwrap_or(false)
    };
    if !run(&["version"]) {
        return None;
    }
    std::fs::write(
        dir.join("server.ext"),
        "subjectAltName=DNS:localhost,IP:127.0.0.1\nbasicConstraints=CA:FALSE\nkeyUsage=digitalSignature\nextendedKeyUsage=serverAuth\n",
    )
    .ok()?;
    let ec = [
        "-newkey",
        "ec",
        "-pkeyopt",
        "ec_paramgen_curve:prime256v1",
        "-nodes",
    ];
    let steps: [Vec<&str>; 3] = [
        [
            &["req", "-x509"][..],
            &ec,
            &[
                "-keyout",
                "ca.key",
                "-out",
                "ca.pem",
                "-days",
                "1",
                "-subj",
                "/CN=vertibench test CA",
            ],
        ]
        .concat(),
        [
            &["req"][..],
            &ec,
            &[
                "-keyout",
                "server.key",
                "-out",
                "server.csr",
                "-subj",
                "/CN=localhost",
            ],
        ]
        .concat(),
        vec![
            "x509",
            "-req",
            "-in",
            "server.csr",
            "-CA",
            "ca.pem",
            "-CAkey",
            "ca.key",
            "-CAcreateserial",
            "-out",
            "server.pem",
            "-days",
            "1",
            "-extfile",
            "server.ext",
        ],
    ];
    for s in &steps {
        assert!(run(s), "openssl {s:?} failed");
    }
    Some(())
}

/// A submission of the planner serving at `url` on `tasks`.
pub fn endpoint_submission(name: &str, url: &str, tasks: &[&str]) -> vb_proto::v1::SubmitRequest {
    use vb_proto::v1 as pb;
    pb::SubmitRequest {
        name: name.into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Endpoint(url.into())),
        }),
        task_ids: tasks.iter().map(|s| s.to_string()).collect(),
        ..Default::default()
    }
}

/// Whether this machine gives exec planners namespaces (as `user`, or the worker's own); prints why not (the tests
/// that need them are then skipped: the worker refuses exec planners there, which its own log says).
pub async fn namespaces_available(user: Option<&str>) -> bool {
    let user = user.map(|u| vb_worker::sandbox::PlannerUser::lookup(u).expect("the user"));
    match vb_worker::sandbox::Containment::probe(user).await {
        Ok(_) => true,
        Err(why) => {
            eprintln!("SKIPPED: {why}");
            false
        }
    }
}

/// A submission of the exec planner `argv` on `tasks`, with a 2 s step deadline.
pub fn exec_argv_submission(
    name: &str,
    tasks: &[&str],
    argv: Vec<String>,
) -> vb_proto::v1::SubmitRequest {
    use vb_proto::v1 as pb;
    pb::SubmitRequest {
        name: name.into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner { argv })),
        }),
        task_ids: tasks.iter().map(|s| s.to_string()).collect(),
        step_deadline_s: 2.0,
        ..Default::default()
    }
}
