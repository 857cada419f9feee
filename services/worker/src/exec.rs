//! Planner processes the worker starts (`exec` and `image` submissions). The user's code runs in its own process (or
//! container), never inside the worker: it serves the `Planner` gRPC service on the address the worker gives it in
//! the environment variable `VB_PLANNER_ADDR` (`127.0.0.1:PORT`), and its stdout and stderr become the episode's
//! planner log.

use crate::remote::{PlannerLog, RemotePlanner, SharedLog};
use sha2::{Digest, Sha256};
use sim_core::planner::PlannerError;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::io::{AsyncBufReadExt, AsyncRead, BufReader};
use tokio::process::{Child, Command};

/// Environment variable that tells a planner process where to serve.
pub const ADDR_ENV: &str = "VB_PLANNER_ADDR";

/// A running planner process; killed when dropped.
pub struct PlannerProcess {
    child: Child,
    pub addr: String,
    pub output: SharedLog,
    pub identity: String,
}

impl PlannerProcess {
    /// Stops the process (it has served its episode).
    pub async fn stop(mut self) {
        let _ = self.child.start_kill();
        let _ = tokio::time::timeout(Duration::from_secs(5), self.child.wait()).await;
    }
}

fn free_port() -> Result<u16, PlannerError> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")
        .map_err(|e| PlannerError::Other(format!("no free local port for the planner: {e}")))?;
    l.local_addr()
        .map(|a| a.port())
        .map_err(|e| PlannerError::Other(e.to_string()))
}

fn capture(stream: impl AsyncRead + Unpin + Send + 'static, log: SharedLog, prefix: &'static str) {
    tokio::spawn(async move {
        let mut lines = BufReader::new(stream).lines();
        while let Ok(Some(line)) = lines.next_line().await {
            if let Ok(mut l) = log.lock() {
                l.push_line(&format!("{prefix}{line}"));
            }
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
/// connected planner.
pub async fn start(
    argv: &[String],
    identity: String,
    step_deadline: Duration,
    startup: Duration,
) -> Result<(PlannerProcess, RemotePlanner), (PlannerError, String)> {
    let output: SharedLog = Arc::new(Mutex::new(PlannerLog::default()));
    let log_text = |o: &SharedLog| o.lock().map(|l| l.text()).unwrap_or_default();
    let Some(program) = argv.first() else {
        return Err((
            PlannerError::Other("empty planner command".into()),
            String::new(),
        ));
    };
    let port = free_port().map_err(|e| (e, String::new()))?;
    let addr = format!("127.0.0.1:{port}");
    let mut child = Command::new(program)
        .args(&argv[1..])
        .env(ADDR_ENV, &addr)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .kill_on_drop(true)
        .spawn()
        .map_err(|e| {
            (
                PlannerError::Crashed(format!("cannot start planner `{program}`: {e}")),
                String::new(),
            )
        })?;
    if let Some(out) = child.stdout.take() {
        capture(out, output.clone(), "");
    }
    if let Some(err) = child.stderr.take() {
        capture(err, output.clone(), "");
    }
    let t0 = Instant::now();
    let endpoint = format!("http://{addr}");
    loop {
        if let Ok(Some(status)) = child.try_wait() {
            // Let the output readers drain.
            tokio::time::sleep(Duration::from_millis(100)).await;
            let text = log_text(&output);
            let tail = output.lock().map(|l| l.tail(600)).unwrap_or_default();
            return Err((
                PlannerError::Crashed(format!(
                    "planner process `{program}` exited ({status}) before serving on {addr}; last output:\n{tail}"
                )),
                text,
            ));
        }
        if let Ok(mut p) =
            RemotePlanner::connect(&endpoint, step_deadline, Duration::from_millis(500)).await
        {
            p.set_crash_context(output.clone());
            let process = PlannerProcess {
                child,
                addr,
                output,
                identity,
            };
            return Ok((process, p));
        }
        if t0.elapsed() > startup {
            let _ = child.start_kill();
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

/// The command that runs a container planner, and its identity (the image id as Docker reports it). The container
/// shares the host network so it can serve on `VB_PLANNER_ADDR`; it gets no volumes.
pub async fn image_command(image: &str) -> Result<(Vec<String>, String), String> {
    let out = Command::new("docker")
        .args(["image", "inspect", "--format", "{{.Id}}", image])
        .output()
        .await
        .map_err(|e| format!("docker is not available on this worker: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "docker image inspect {image} failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let id = String::from_utf8_lossy(&out.stdout).trim().to_string();
    let argv = vec![
        "docker".into(),
        "run".into(),
        "--rm".into(),
        "--network".into(),
        "host".into(),
        "--cap-drop".into(),
        "ALL".into(),
        "--security-opt".into(),
        "no-new-privileges".into(),
        "-e".into(),
        ADDR_ENV.into(),
        image.into(),
    ];
    Ok((argv, format!("image:{image}@{id}")))
}
