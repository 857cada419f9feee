//! Planner processes the worker starts (`exec` and `image` submissions). The user's code runs in its own process (or
//! container), never inside the worker: it serves the `Planner` gRPC service on the address the worker gives it in
//! the environment variable `VB_PLANNER_ADDR` (`127.0.0.1:PORT`), and its stdout and stderr become the episode's
//! planner log (bounded: lines are cut at [`MAX_LINE`] bytes and the log at [`PlannerLog::CAP`], with a marker).
//!
//! Containment of `exec` planners (they are for trusted clusters unless run as another user): each one gets a
//! clean environment (`PATH`, `VB_PLANNER_ADDR`, `HOME` and `TMPDIR`), its own process group, resource limits, a
//! kill when the worker dies, and, where the machine allows (the worker probes at start and otherwise refuses exec
//! planners), PID, mount and IPC namespaces of its own with a private `/proc` and tmpfs temporary directories, its
//! working directory among them ([`crate::sandbox::namespaces`]): everything it starts dies with it, and nothing it
//! wrote stays. Without namespaces (`vb-submit validate` on a machine that has none) it works in a fresh private
//! directory removed after the episode. Image planners run in a named container labelled with their worker,
//! removed when the episode ends, as an unprivileged user, with a read-only root filesystem, no capabilities,
//! memory, CPU and process limits, and no network: the worker talks to it over a Unix socket in the episode's
//! private directory, mounted into the container. A watchdog removes both when the worker dies, even by SIGKILL,
//! and a worker's start removes what dead workers left ([`crate::sandbox::reaper`]).

use crate::remote::{PlannerLog, RemotePlanner, SharedLog};
use crate::sandbox::namespaces::Namespaces;
use crate::sandbox::reaper::{self, Watchdog};
use crate::sandbox::Containment;
use crate::EpisodeError;
use sha2::{Digest, Sha256};
use sim_core::planner::PlannerError;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::io::{AsyncRead, AsyncReadExt};
use tokio::process::{Child, Command};

/// Environment variable that tells a planner process where to serve.
pub const ADDR_ENV: &str = "VB_PLANNER_ADDR";

/// Where an image planner's socket directory is mounted in its container, and the placeholder that
/// [`image_command`] puts in its command line for the host side of that mount (the episode's private directory).
const CONTAINER_SOCKET_DIR: &str = "/run/vb";
const WORKDIR_PLACEHOLDER: &str = "{workdir}";
/// The socket's file name in that directory.
const SOCKET_NAME: &str = "planner.sock";

/// Longest planner output line kept, bytes; the rest of the line is dropped and the line marked.
pub const MAX_LINE: usize = 4096;

/// A running planner process in its own process group, with its private working directory (and, for an image, its
/// container, which its watchdog removes): all of them are killed and removed when it stops or is dropped.
pub struct PlannerProcess {
    child: Child,
    pgid: Option<i32>,
    workdir: Option<PathBuf>,
    watchdog: Option<Watchdog>,
    pub addr: String,
    pub output: SharedLog,
    pub identity: String,
}

impl PlannerProcess {
    /// Stops the process (it has served its episode).
    pub async fn stop(mut self) {
        self.kill_group();
        let _ = self.child.start_kill();
        let waited = tokio::time::timeout(Duration::from_secs(5), self.child.wait()).await;
        if let (Ok(Ok(_)), Some(w)) = (waited, &mut self.watchdog) {
            w.client_exited();
        }
    }

    fn kill_group(&self) {
        if let Some(pgid) = self.pgid {
            use nix::sys::signal::{killpg, Signal};
            let _ = killpg(nix::unistd::Pid::from_raw(pgid), Signal::SIGKILL);
        }
    }
}

impl Drop for PlannerProcess {
    fn drop(&mut self) {
        self.kill_group();
        if let Some(dir) = &self.workdir {
            let _ = std::fs::remove_dir_all(dir);
        }
        // The `docker run` client dies with the group; closing the pipe has the watchdog remove the container.
        drop(self.watchdog.take());
    }
}

/// Makes a fresh private (0700) working directory for one planner process at `dir` ([`reaper::private_dir_path`]).
fn make_private_dir(dir: &Path) -> Result<(), PlannerError> {
    use std::os::unix::fs::DirBuilderExt;
    std::fs::DirBuilder::new()
        .mode(0o700)
        .create(dir)
        .map_err(|e| PlannerError::Other(format!("cannot make {}: {e}", dir.display())))
}

fn free_port() -> Result<u16, PlannerError> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")
        .map_err(|e| PlannerError::Other(format!("no free local port for the planner: {e}")))?;
    l.local_addr()
        .map(|a| a.port())
        .map_err(|e| PlannerError::Other(e.to_string()))
}

/// Copies a planner's output into its log line by line, in bounded memory: a line is cut at [`MAX_LINE`] bytes.
fn capture(stream: impl AsyncRead + Unpin + Send + 'static, log: SharedLog) {
    if let Ok(mut l) = log.lock() {
        l.stream_opened();
    }
    tokio::spawn(async move {
        let mut reader = stream;
        let mut chunk = vec![0u8; 8192];
        let mut line: Vec<u8> = Vec::with_capacity(256);
        let mut cut = false;
        let push = |line: &[u8], cut: bool| {
            if let Ok(mut l) = log.lock() {
                let text = String::from_utf8_lossy(line);
                if cut {
                    l.push_line(&format!("{text} [line cut at {MAX_LINE} bytes]"));
                } else {
                    l.push_line(&text);
                }
            }
        };
        loop {
            let n = match reader.read(&mut chunk).await {
                Ok(0) | Err(_) => break,
                Ok(n) => n,
            };
            for &b in &chunk[..n] {
                if b == b'\n' {
                    push(&line, cut);
                    line.clear();
                    cut = false;
                } else if line.len() < MAX_LINE {
                    line.push(b);
                } else {
                    cut = true;
                }
            }
        }
        if !line.is_empty() {
            push(&line, cut);
        }
        if let Ok(mut l) = log.lock() {
            l.stream_closed();
        }
    });
}

fn resolve(program: &str) -> Option<PathBuf> {
    let p = Path::new(program);
    if p.components().count() > 1 {
        return p.is_file().then(|| p.to_path_buf());
    }
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(program))
            .find(|c| c.is_file())
    })
}

/// What identifies an exec planner's code: its command line and the SHA-256 of its executable.
pub fn exec_identity(argv: &[String]) -> String {
    let digest = argv
        .first()
        .and_then(|p| resolve(p))
        .and_then(|p| std::fs::read(p).ok())
        .map(|bytes| {
            let d = Sha256::digest(&bytes);
            d.iter()
                .take(12)
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        })
        .unwrap_or_else(|| "unknown".into());
    format!("exec:{} (sha256:{digest})", argv.join(" "))
}

/// Starts `argv` with `VB_PLANNER_ADDR` set and waits (up to `startup`) until it serves; returns the process and a
/// connected planner. `image`: `argv` is an [`image_command`] (else an exec planner's own command).
///
/// One piece on purpose: it acquires the planner's resources in the one order that leaves nothing behind when the
/// worker dies at any point (the watchdog, then the private directory, its owner, the address, the process group,
/// and only then `PlannerProcess`, whose drop releases them all), and each early return releases exactly what was
/// acquired before it; that order is the function's contract and reads top to bottom here.
pub async fn start(
    argv: &[String],
    image: bool,
    identity: String,
    step_deadline: Duration,
    startup: Duration,
    containment: Containment,
) -> Result<(PlannerProcess, RemotePlanner), (PlannerError, String)> {
    let output: SharedLog = Arc::new(Mutex::new(PlannerLog::default()));
    let log_text = |o: &SharedLog| o.lock().map(|l| l.text()).unwrap_or_default();
    let Some(program) = argv.first() else {
        return Err((
            PlannerError::Other("empty planner command".into()),
            String::new(),
        ));
    };
    // An image planner has no network: it serves on a Unix socket in the episode's private directory on the host,
    // mounted into its container (whose own namespaces contain it); an exec planner serves on a free loopback port.
    // Said by the caller, never read off the command: an exec planner naming the placeholder would otherwise run
    // uncontained and as the worker's user.
    let contained = image;
    // An exec planner in namespaces of its own works in its private tmpfs `/tmp`: nothing on the host to remove.
    let isolated = containment.namespaces && !contained;
    let user = containment.user.filter(|_| !contained);
    let fail = |e: String| (PlannerError::Other(e), String::new());
    let workdir = if isolated {
        None
    } else {
        Some(reaper::private_dir_path().map_err(fail)?)
    };
    // An image planner's watchdog starts first: whenever the worker dies from here on, it removes the container
    // and the directory.
    let watchdog = match (contained, container_name(argv), &workdir) {
        (true, Some(name), Some(dir)) => Some(Watchdog::spawn(&name, dir).map_err(|e| {
            fail(format!(
                "cannot start the watchdog that removes the planner's container: {e}"
            ))
        })?),
        (true, _, _) => return Err(fail("an image planner without a container name".into())),
        _ => None,
    };
    if let Some(dir) = &workdir {
        make_private_dir(dir).map_err(|e| (e, String::new()))?;
    }
    if let (Some(u), Some(dir)) = (user, &workdir) {
        if let Err(e) = std::os::unix::fs::chown(dir, Some(u.uid), Some(u.gid)) {
            let _ = std::fs::remove_dir_all(dir);
            let msg = format!("cannot give the planner's directory to uid {}: {e}", u.uid);
            return Err((PlannerError::Other(msg), String::new()));
        }
    }
    let (addr, endpoint) = match (&workdir, contained) {
        (Some(dir), true) => {
            // The container's unprivileged user must be able to create the socket.
            if std::os::unix::fs::chown(dir, Some(65534), Some(65534)).is_err() {
                use std::os::unix::fs::PermissionsExt;
                let _ = std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o777));
            }
            (
                format!("unix:{CONTAINER_SOCKET_DIR}/{SOCKET_NAME}"),
                format!("unix:{}", dir.join(SOCKET_NAME).display()),
            )
        }
        _ => {
            let port = free_port().map_err(|e| (e, String::new()))?;
            (
                format!("127.0.0.1:{port}"),
                format!("http://127.0.0.1:{port}"),
            )
        }
    };
    // Where the planner works and keeps its files, as it sees it.
    let home = match &workdir {
        Some(dir) => dir.clone(),
        None => PathBuf::from("/tmp"),
    };
    let workdir_text = home.display().to_string();
    let argv: Vec<String> = argv
        .iter()
        .map(|a| {
            if contained {
                a.replace(WORKDIR_PLACEHOLDER, &workdir_text)
            } else {
                a.clone()
            }
        })
        .collect();
    let path = std::env::var_os("PATH").unwrap_or_else(|| "/usr/local/bin:/usr/bin:/bin".into());
    let limits = crate::sandbox::Limits::default();
    let containment = Containment {
        namespaces: isolated,
        user,
    };
    let namespaces = Namespaces::new(user.map(|u| (u.uid, u.gid)), &argv);
    // Only a planner that fails to start needs it (it reads the file system).
    let sandbox = || {
        if isolated {
            sandbox_note(&argv)
        } else {
            String::new()
        }
    };
    let mut command = Command::new(&argv[0]);
    // SAFETY: the closure runs in the forked child before `exec`; `apply_in_child` makes only async-signal-safe
    // system calls (setrlimit, prctl, unshare, fork, mount, setgroups, setgid, setuid) on memory prepared here.
    #[allow(unsafe_code)]
    unsafe {
        command.pre_exec(move || containment.apply_in_child(&limits, &namespaces));
    }
    // The child changes into its tmpfs `/tmp` itself once that is mounted.
    let start_dir = workdir.clone().unwrap_or_else(|| PathBuf::from("/"));
    let spawned = command
        .args(&argv[1..])
        .env_clear()
        .env("PATH", path)
        .env("HOME", &home)
        .env("TMPDIR", &home)
        .env("LANG", "C.UTF-8")
        .env(ADDR_ENV, &addr)
        .current_dir(&start_dir)
        .process_group(0)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn();
    let mut child = match spawned {
        Ok(c) => c,
        Err(e) => {
            if let Some(dir) = &workdir {
                let _ = std::fs::remove_dir_all(dir);
            }
            return Err((
                PlannerError::Crashed(format!(
                    "cannot start planner `{program}`: {e}{}",
                    sandbox()
                )),
                String::new(),
            ));
        }
    };
    // From here on, dropping `process` kills the group and removes the directory and the container.
    let mut process = PlannerProcess {
        pgid: child.id().map(|id| id as i32),
        workdir,
        watchdog,
        addr,
        output: output.clone(),
        identity,
        child: {
            if let Some(out) = child.stdout.take() {
                capture(out, output.clone());
            }
            if let Some(err) = child.stderr.take() {
                capture(err, output.clone());
            }
            child
        },
    };
    let addr = process.addr.clone();
    let t0 = Instant::now();
    loop {
        if let Ok(Some(status)) = process.child.try_wait() {
            // Let the output readers drain.
            tokio::time::sleep(Duration::from_millis(100)).await;
            let text = log_text(&output);
            let tail = output.lock().map(|l| l.tail(600)).unwrap_or_default();
            return Err((
                PlannerError::Crashed(format!(
                    "planner process `{program}` exited ({status}) before serving on {addr}{}; last output:\n{tail}",
                    sandbox()
                )),
                text,
            ));
        }
        match RemotePlanner::connect(&endpoint, step_deadline, Duration::from_millis(500)).await {
            Ok(mut p) => {
                p.set_crash_context(output.clone());
                return Ok((process, p));
            }
            // The planner served and answered wrongly (a bad control rate, ...): its fault, reported as such at
            // once rather than retried until the startup timeout. Not yet listening: try again.
            Err(e @ (PlannerError::Protocol(_) | PlannerError::Timeout(_))) => {
                drop(process);
                return Err((e, log_text(&output)));
            }
            Err(_) => {}
        }
        if t0.elapsed() > startup {
            drop(process);
            let text = log_text(&output);
            return Err((
                PlannerError::Timeout(format!(
                    "planner process `{program}` did not serve on {addr} within {:.0} s (it must serve gRPC on ${ADDR_ENV})",
                    startup.as_secs_f64()
                )),
                text,
            ));
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// What the sandbox hides, for the message of a planner that did not start: a missing file is then often one the
/// sandbox does not show.
fn sandbox_note(argv: &[String]) -> String {
    let shown = crate::sandbox::namespaces::visible_paths(argv);
    let shown = if shown.is_empty() {
        "none".to_string()
    } else {
        shown
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    };
    format!(
        " (its sandbox has a private /tmp, /var/tmp and /dev/shm: of the host's files there it sees only the \
         top-level folders its command names, read-only: {shown}; the worker's secrets read as empty)"
    )
}

/// The container name in a `docker run --name NAME ...` command line.
fn container_name(argv: &[String]) -> Option<String> {
    if argv.first().map(String::as_str) != Some("docker") {
        return None;
    }
    argv.windows(2)
        .find(|w| w[0] == "--name")
        .map(|w| w[1].clone())
}

/// Whether this machine can run image planners: a Docker daemon answers (within 10 s). `Err` says why not.
pub async fn docker_available() -> Result<(), String> {
    let probe = Command::new("docker")
        .args(["version", "--format", "{{.Server.Version}}"])
        .output();
    match tokio::time::timeout(std::time::Duration::from_secs(10), probe).await {
        Err(_) => Err("`docker version` did not answer within 10 s".into()),
        Ok(Err(e)) => Err(format!("no docker command: {e}")),
        Ok(Ok(out)) if !out.status.success() => Err(format!(
            "no Docker daemon: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        )),
        Ok(Ok(_)) => Ok(()),
    }
}

/// The command that runs a container planner, and its identity (the image id as Docker reports it). The container
/// is named and labelled with this worker ([`reaper::LABEL`]), so it can be removed when the episode ends or the
/// worker dies; it runs as nobody (65534) with a read-only root filesystem (a 64 MB `/tmp`), no capabilities, 2 GB of
/// memory, one CPU and 256 processes, and no network: it serves on a Unix socket
/// (`VB_PLANNER_ADDR=unix:/run/vb/planner.sock`) in the episode's private directory, its only volume.
pub async fn image_command(image: &str) -> Result<(Vec<String>, String), EpisodeError> {
    // The coordinator checked it at submission; a worker checks again before it reaches a command line, and passes
    // it after `--` so nothing in it can read as an option.
    contracts::input::check_image_ref(image).map_err(|e| e.to_string())?;
    let out = Command::new("docker")
        .args(["image", "inspect", "--format", "{{.Id}}", "--", image])
        .output()
        .await
        .map_err(|e| format!("docker is not available on this worker: {e}"))?;
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr).trim().to_string();
        // Another worker may have the image: this one cannot run the submission at all.
        if err.to_ascii_lowercase().contains("no such image") {
            return Err(EpisodeError::CannotRun(format!(
                "this worker has no image `{image}`: {err}"
            )));
        }
        return Err(format!("docker image inspect {image} failed: {err}").into());
    }
    let id = String::from_utf8_lossy(&out.stdout).trim().to_string();
    // Labelled with this worker, so that a worker starting on this machine can tell whether its owner is dead.
    let owner = reaper::Owner::current().map_err(|e| {
        EpisodeError::CannotRun(format!("this worker cannot label containers: {e}"))
    })?;
    let mut name = [0u8; 8];
    getrandom::getrandom(&mut name).map_err(|e| e.to_string())?;
    let name: String = name.iter().map(|b| format!("{b:02x}")).collect();
    let argv = [
        "docker",
        "run",
        "--rm",
        "--name",
        &format!("vb-planner-{name}"),
        "--label",
        &format!("{}={}", reaper::LABEL, owner.label()),
        "--network",
        "none",
        "--volume",
        &format!("{WORKDIR_PLACEHOLDER}:{CONTAINER_SOCKET_DIR}"),
        "--user",
        "65534:65534",
        "--read-only",
        "--tmpfs",
        "/tmp:rw,size=64m",
        "--cap-drop",
        "ALL",
        "--security-opt",
        "no-new-privileges",
        "--memory",
        "2g",
        "--cpus",
        "1",
        "--pids-limit",
        "256",
        "-e",
        ADDR_ENV,
        "--",
        image,
    ]
    .map(String::from)
    .to_vec();
    Ok((argv, format!("image:{image}@{id}")))
}
