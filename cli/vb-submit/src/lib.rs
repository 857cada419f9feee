//! Client side of the submission API (`vb-submit`, and `vb serve` when it evaluates a planner): submit, follow,
//! cancel, fetch results, and validate a planner locally before queueing 1000 episodes.

// tonic::Status is large (176 bytes) and is the error type of every gRPC handler; boxing it everywhere buys nothing.
#![allow(clippy::result_large_err)]

pub mod cli;
pub mod results;
#[cfg(feature = "validate")]
pub mod validate;
#[cfg(feature = "validate")]
pub use validate::{validate, Validation};

/// A planner command with every argument that names an existing file or directory relative to the caller's
/// directory made absolute: workers start planners in a private directory of their own, so `python my_planner.py`
/// must say where `my_planner.py` is.
pub fn absolute_paths(argv: &[String]) -> Vec<String> {
    argv.iter()
        .map(|a| {
            let p = Path::new(a);
            if a.starts_with('-') || p.is_absolute() || !p.exists() || !a.contains(['/', '.']) {
                return a.clone();
            }
            p.canonicalize()
                .map_or_else(|_| a.clone(), |c| c.display().to_string())
        })
        .collect()
}

use std::path::Path;
use tonic::metadata::MetadataValue;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;
use tonic::{Request, Status};
use vb_proto::v1 as pb;
use vb_proto::v1::coordinator_client::CoordinatorClient;
use vb_proto::ProtoEnum;

pub use vb_proto::v1::{PlannerRef, SubmissionStatus, SubmitRequest};

#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error("cannot reach the coordinator at {url}: {message}")]
    Connect { url: String, message: String },
    #[error("{0}")]
    Rpc(String),
    #[error("{0}")]
    Usage(String),
    /// The coordinator sent something this client cannot read.
    #[error("unexpected answer from the coordinator: {0}")]
    Protocol(String),
    #[error("{0}")]
    Io(String),
}

/// A readable message for a refused call.
pub fn describe(s: &Status) -> String {
    let what = match s.code() {
        tonic::Code::Unauthenticated => "authentication failed",
        tonic::Code::NotFound => "not found",
        tonic::Code::InvalidArgument => "invalid request",
        tonic::Code::PermissionDenied => "not allowed",
        tonic::Code::ResourceExhausted => "request too large",
        tonic::Code::Unavailable => "coordinator unavailable",
        tonic::Code::DeadlineExceeded => "timed out",
        // tonic's own deadline ([`rpc_timeout`]) ends a call as cancelled, "Timeout expired".
        tonic::Code::Cancelled if s.message() == "Timeout expired" => {
            return format!(
                "no answer from the coordinator within {:.0} s (is it overloaded, or not a vertibench coordinator? \
                 {RPC_TIMEOUT_ENV} sets the limit)",
                rpc_timeout().as_secs_f64()
            )
        }
        _ => "coordinator error",
    };
    format!("{what}: {}", s.message())
}

fn rpc(s: Status) -> SubmitError {
    SubmitError::Rpc(describe(&s))
}

#[derive(Clone)]
pub struct Auth(MetadataValue<tonic::metadata::Ascii>);

impl tonic::service::Interceptor for Auth {
    fn call(&mut self, mut req: Request<()>) -> Result<Request<()>, Status> {
        req.metadata_mut().insert("authorization", self.0.clone());
        Ok(req)
    }
}

/// An error with its causes (`transport error: ... : invalid peer certificate: UnknownIssuer`).
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut cur = e.source();
    while let Some(c) = cur {
        s += &format!(": {c}");
        cur = c.source();
    }
    s
}

pub type Client = CoordinatorClient<InterceptedService<Channel, Auth>>;

/// How long a connection (TCP and HTTP/2) may take.
pub const CONNECT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(10);

/// How long a call may wait for the coordinator's answer (a streamed call: for its headers), 60 s unless
/// [`RPC_TIMEOUT_ENV`] says otherwise: a server that accepts and never answers, or drops the connection in a way
/// the client misses, is an error, not a hang.
pub fn rpc_timeout() -> std::time::Duration {
    std::env::var(RPC_TIMEOUT_ENV)
        .ok()
        .and_then(|v| v.trim().parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0 && *s < 1e6)
        .map_or(
            std::time::Duration::from_secs(60),
            std::time::Duration::from_secs_f64,
        )
}

/// The variable that sets [`rpc_timeout`], in seconds.
pub const RPC_TIMEOUT_ENV: &str = "VB_SUBMIT_RPC_TIMEOUT_S";

/// Connects to the coordinator's public API with a token; `https://` URLs use TLS, verified against `ca` (PEM) when
/// given, else against the public web PKI roots.
pub async fn connect(url: &str, token: &str, ca: Option<&Path>) -> Result<Client, SubmitError> {
    let header: MetadataValue<_> = format!("Bearer {}", token.trim()).parse().map_err(|_| {
        SubmitError::Usage("the token contains characters that cannot be sent in a header".into())
    })?;
    let endpoint = vb_proto::tls::endpoint(url, ca)
        .map_err(|message| SubmitError::Connect {
            url: url.into(),
            message,
        })?
        .timeout(rpc_timeout());
    let connecting = tokio::time::timeout(CONNECT_TIMEOUT, endpoint.connect());
    let channel = connecting
        .await
        .map_err(|_| SubmitError::Connect {
            url: url.into(),
            message: format!(
                "no connection within {} s (is `vb serve` or `vb coordinator` running there?)",
                CONNECT_TIMEOUT.as_secs()
            ),
        })?
        .map_err(|e| SubmitError::Connect {
            url: url.into(),
            message: format!(
                "{} (is `vb serve` or `vb coordinator` running there, with TLS when the URL is https://?)",
                error_chain(&e)
            ),
        })?;
    Ok(CoordinatorClient::with_interceptor(channel, Auth(header)))
}

pub async fn submit(
    client: &mut Client,
    req: SubmitRequest,
) -> Result<pb::SubmitResponse, SubmitError> {
    Ok(client.submit(req).await.map_err(rpc)?.into_inner())
}

pub async fn status(client: &mut Client, id: &str) -> Result<SubmissionStatus, SubmitError> {
    Ok(client
        .status(pb::StatusRequest {
            submission_id: id.into(),
        })
        .await
        .map_err(rpc)?
        .into_inner())
}

pub async fn list(client: &mut Client) -> Result<Vec<SubmissionStatus>, SubmitError> {
    Ok(client
        .list_submissions(pb::ListRequest {})
        .await
        .map_err(rpc)?
        .into_inner()
        .submissions)
}

pub async fn cancel(client: &mut Client, id: &str) -> Result<SubmissionStatus, SubmitError> {
    Ok(client
        .cancel(pb::CancelRequest {
            submission_id: id.into(),
        })
        .await
        .map_err(rpc)?
        .into_inner())
}

pub async fn results(client: &mut Client, id: &str) -> Result<pb::ResultsResponse, SubmitError> {
    Ok(client
        .results(pb::StatusRequest {
            submission_id: id.into(),
        })
        .await
        .map_err(rpc)?
        .into_inner())
}

/// The planner log of one episode of the caller's own submission.
pub async fn episode_log(
    client: &mut Client,
    id: &str,
    task: contracts::TaskId,
) -> Result<String, SubmitError> {
    Ok(client
        .episode_log(pb::EpisodeLogRequest {
            submission_id: id.into(),
            task_id: task.to_string(),
        })
        .await
        .map_err(rpc)?
        .into_inner()
        .planner_log)
}

/// Writes the planner log of every finished episode of `r` (the caller's own submission) that has one to
/// `dir/TASK.log`; how many.
pub async fn write_logs(
    client: &mut Client,
    r: &pb::ResultsResponse,
    dir: &Path,
) -> Result<usize, SubmitError> {
    let id = r.status.as_ref().map_or("", |s| s.submission_id.as_str());
    std::fs::create_dir_all(dir)
        .map_err(|e| SubmitError::Io(format!("cannot make {}: {e}", dir.display())))?;
    let mut n = 0;
    for e in r
        .episodes
        .iter()
        .filter(|e| e.state() == pb::EpisodeState::Done)
    {
        // A task id is `wNNN-tK` (checked), so it names a file safely.
        let task: contracts::TaskId = e.task_id.parse().map_err(|_| {
            SubmitError::Protocol(format!("task id `{}` in the results", e.task_id))
        })?;
        let log = episode_log(client, id, task).await?;
        if log.is_empty() {
            continue;
        }
        let path = dir.join(format!("{task}.log"));
        std::fs::write(&path, log)
            .map_err(|e| SubmitError::Io(format!("cannot write {}: {e}", path.display())))?;
        n += 1;
    }
    Ok(n)
}

/// Follows a submission's progress stream until it ends, calling `on` with every update; returns the last status.
pub async fn watch(
    client: &mut Client,
    id: &str,
    mut on: impl FnMut(&SubmissionStatus),
) -> Result<SubmissionStatus, SubmitError> {
    let mut stream = client
        .watch_progress(pb::StatusRequest {
            submission_id: id.into(),
        })
        .await
        .map_err(rpc)?
        .into_inner();
    let mut last = None;
    while let Some(s) = stream.message().await.map_err(rpc)? {
        on(&s);
        last = Some(s);
    }
    last.ok_or_else(|| SubmitError::Rpc("the progress stream ended without a status".into()))
}

fn fmt_duration(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    if s >= 3600 {
        format!("{}h{:02}m", s / 3600, (s % 3600) / 60)
    } else if s >= 60 {
        format!("{}m{:02}s", s / 60, s % 60)
    } else {
        format!("{s}s")
    }
}

/// A line of `vb-submit status`'s list: the status line and the submission's name, shown escaped
/// ([`contracts::input::shown`]: a name stored before such characters were refused cannot reorder or hide the line).
pub fn list_line(s: &SubmissionStatus) -> String {
    format!("{}  {}", status_line(s), contracts::input::shown(&s.name))
}

/// One line: state, a progress bar, counts, queue position and ETA.
pub fn status_line(s: &SubmissionStatus) -> String {
    let width = 30;
    let filled = if s.total == 0 {
        0
    } else {
        (width as u64 * s.finished as u64 / s.total as u64) as usize
    };
    let bar = format!("[{}{}]", "#".repeat(filled), ".".repeat(width - filled));
    let state = contracts::SubmissionState::from_wire(s.state).ok();
    let mut line = format!(
        "{} {:<9} {bar} {}/{} done, {} running, success {:.1}%",
        s.submission_id,
        state.map_or("unknown", contracts::SubmissionState::as_str),
        s.finished,
        s.total,
        s.running,
        100.0 * s.success_rate
    );
    if state.is_some_and(contracts::SubmissionState::is_active) {
        if s.queue_position > 0 {
            line += &format!(", {} submissions ahead", s.queue_position);
        }
        line += &if s.eta_known {
            format!(", ETA {}", fmt_duration(s.eta_s))
        } else {
            ", ETA unknown (no episode finished recently)".to_string()
        };
    }
    if s.not_run > 0 {
        line += &format!(", {} not run", s.not_run);
    }
    if !s.perception.is_empty() && s.perception != "ideal" {
        line += &format!(", perception {}", s.perception);
    }
    line
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_listed_name_shows_hidden_characters_escaped() {
        let s = super::SubmissionStatus {
            submission_id: "s1".into(),
            name: "evil\u{202E}gnp.exe\u{200B}".into(),
            state: vb_proto::ProtoEnum::wire(contracts::SubmissionState::Done),
            ..Default::default()
        };
        let line = super::list_line(&s);
        assert!(
            line.ends_with("  evil\\u{202E}gnp.exe\\u{200B}") && line.starts_with("s1 done"),
            "{line}"
        );
        assert!(!line.contains(['\u{202E}', '\u{200B}']), "{line}");
    }
}
