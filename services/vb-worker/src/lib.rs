//! The worker of the evaluation service: registers with the coordinator, leases episodes, runs each one with
//! sim-core on a blocking thread against its planner (built-in, a remote gRPC endpoint, a process or a container it
//! starts), heartbeats its leases, and reports every finished episode with its metrics, a compact trajectory and the
//! planner's log. It never touches the database.
//!
//! Failure model: a worker can die at any moment (its leases expire and the coordinator re-queues the episodes);
//! a planner's own failure (crash, hang, NaN, protocol error) is the episode's result, reported and not retried;
//! a report that cannot be delivered is retried until the coordinator is back.

// tonic::Status is large (176 bytes) and is the error type of every gRPC handler; boxing it everywhere buys nothing.
#![allow(clippy::result_large_err)]

pub mod convert;
pub mod exec;
mod pool;
pub mod remote;
pub mod sandbox;
pub mod sim_access;
pub mod sim_service;
mod startup;
// The client's TLS setup is the protocol crate's (vb-submit uses it without the worker).
pub use vb_proto::tls;

pub use pool::run_worker;
// The perception layer an episode spec names (the CLIs that build specs use it through here).
pub use perception;

use remote::{PlannerLog, RemotePlanner, SharedLog};
use sim_core::episode::{EndReason, EpisodeConfig, EpisodeResult, Outcome};
use sim_core::planner::{Action, Planner, PlannerError, VehicleState};
use sim_core::runner::EpisodeObserver;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tasks::TaskSet;
use vb_proto::v1 as pb;

/// Version of the simulator this worker runs (must match the coordinator's).
pub use sim_core::SIM_VERSION;

/// Trajectory recording rate of service episodes, Hz.
pub const RECORD_HZ: f64 = 5.0;

#[derive(Debug, thiserror::Error)]
pub enum WorkerError {
    #[error(transparent)]
    Tasks(#[from] tasks::TasksError),
    #[error("bad coordinator address `{0}`: {1}")]
    Address(String, String),
    #[error("coordinator refused this worker: {0}")]
    Refused(String),
}

#[derive(Clone, Debug)]
pub struct WorkerConfig {
    /// CA certificate (PEM) that an `https://` coordinator's certificate is verified against (None: the public web
    /// PKI roots).
    pub tls_ca: Option<PathBuf>,
    /// Coordinator URL, e.g. `http://127.0.0.1:50051`.
    pub coordinator: String,
    pub name: String,
    /// Episodes run at once.
    pub slots: usize,
    pub task_dir: PathBuf,
    /// How long a started planner process may take to serve, s.
    pub planner_startup_s: f64,
    /// Whether this worker runs `exec` and `image` planners (untrusted code: for trusted clusters only).
    pub allow_exec: bool,
    /// The worker token (`vb admin token create --role worker`) sent with every call to the coordinator.
    pub token: String,
    /// Run exec planners as this (unprivileged) user.
    pub planner_user: Option<sandbox::PlannerUser>,
    /// On shutdown, how long running episodes get to finish before the rest are stopped and handed back.
    pub drain: Duration,
}

enum AnyPlanner {
    Builtin(Box<dyn Planner>),
    Remote(Box<RemotePlanner>),
}

impl AnyPlanner {
    fn as_dyn(&mut self) -> &mut dyn Planner {
        match self {
            AnyPlanner::Builtin(p) => p.as_mut(),
            AnyPlanner::Remote(p) => p.as_mut(),
        }
    }
}

fn kind_ref(p: &pb::PlannerRef) -> Option<&pb::planner_ref::Kind> {
    p.kind.as_ref()
}

struct CancelObserver(Arc<AtomicBool>);

impl EpisodeObserver for CancelObserver {
    fn on_control_step(&mut self, _: &VehicleState, _: &Action) -> ControlFlow<()> {
        if self.0.load(Ordering::Relaxed) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    }
}

/// Trajectory as CSV (angles in radians), gzip-compressed.
pub fn trajectory_gzip(r: &EpisodeResult) -> Vec<u8> {
    let csv = sim_core::trajectory::to_csv(&r.trajectory);
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    // Writing to a Vec cannot fail.
    let _ = enc.write_all(csv.as_bytes());
    enc.finish().unwrap_or_default()
}

/// Everything needed to run one episode, independent of where it came from (a lease, `vb-submit validate`).
#[derive(Clone, Debug)]
pub struct EpisodeSpec {
    pub task_id: contracts::TaskId,
    pub planner: pb::PlannerRef,
    pub vehicle: contracts::VehicleId,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    /// Overrides the default 60 s time limit (validation runs are short).
    pub max_time: Option<f64>,
    /// How exec planners are contained (namespaces, another user).
    pub containment: sandbox::Containment,
    /// The perception profile between the truth and the planner (`Profile::ideal()`: ground truth).
    pub perception: perception::Profile,
}

/// The lease's perception profile: ideal, or parsed from its parameters and checked against its identity (a
/// worker whose `perception` crate differs from the coordinator's must not run it under another profile).
pub fn lease_profile(identity: &str, params: &str) -> Result<perception::Profile, String> {
    if params.is_empty() && (identity.is_empty() || identity == "ideal") {
        return Ok(perception::Profile::ideal());
    }
    let p = perception::Profile::from_json(params)
        .map_err(|e| format!("lease's perception profile {identity}: {e}"))?;
    if p.identity() != identity {
        return Err(format!(
            "lease's perception profile is {identity} but its parameters are {} here (another build of the \
             perception layer)",
            p.identity()
        ));
    }
    Ok(p)
}

/// A finished episode, ready to report.
#[derive(Clone, Debug)]
pub struct FinishedEpisode {
    pub result: EpisodeResult,
    pub planner_log: String,
    pub planner_identity: String,
    pub wall_time_s: f64,
    /// Round-trip times of the remote planner's control steps, s (empty for built-in planners).
    pub round_trips: Vec<f64>,
}

fn failed(
    reason: EndReason,
    e: &PlannerError,
    log: String,
    identity: String,
    t0: Instant,
) -> FinishedEpisode {
    FinishedEpisode {
        result: EpisodeResult {
            outcome: Outcome::PlannerFailure,
            reason,
            detail: e.to_string(),
            metrics: Default::default(),
            trajectory: Vec::new(),
        },
        planner_log: log,
        planner_identity: identity,
        wall_time_s: t0.elapsed().as_secs_f64(),
        round_trips: Vec::new(),
    }
}

/// Why a worker could not run an episode (never the planner's fault).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum EpisodeError {
    /// This worker cannot run the submission at all (it lacks the image); another worker may.
    #[error("{0}")]
    CannotRun(String),
    /// Anything else: the coordinator retries the episode, up to its attempts.
    #[error("{0}")]
    Infrastructure(String),
}

impl From<String> for EpisodeError {
    fn from(why: String) -> Self {
        EpisodeError::Infrastructure(why)
    }
}

/// Runs one episode. `Err` means the worker could not run it (not the planner's fault): the coordinator re-queues
/// it. Planner failures are an `Ok` run with outcome `planner_failure`.
pub async fn run_leased(
    set: Arc<TaskSet>,
    spec: EpisodeSpec,
    cancel: Arc<AtomicBool>,
    planner_startup: Duration,
) -> Result<FinishedEpisode, EpisodeError> {
    let t0 = Instant::now();
    let (w, t) = (spec.task_id.world, spec.task_id.index);
    let vehicle = sim_core::vehicle::vehicle_by_name(&spec.vehicle).map_err(|e| e.to_string())?;
    let task = set
        .tasks(w, spec.scale)
        .map_err(|e| e.to_string())?
        .into_iter()
        .nth(t as usize)
        .ok_or_else(|| format!("no task {} in world {w}", t))?;
    let mut cfg = EpisodeConfig {
        seed: spec.seed,
        record_hz: Some(RECORD_HZ),
        ..EpisodeConfig::default()
    };
    if let Some(m) = spec.max_time {
        cfg.max_time = m;
    }
    let deadline = Duration::from_secs_f64(spec.step_deadline_s.clamp(0.001, 60.0));
    let log: SharedLog = Arc::new(Mutex::new(PlannerLog::default()));
    let (planner, identity, process) =
        match start_planner(&set, &spec, deadline, planner_startup, &log, t0).await? {
            Started::Ready(planner, identity, process) => (planner, identity, process),
            Started::Failed(f) => return Ok(f),
        };
    let scale = spec.scale;
    let world_set = set.clone();
    let joined = tokio::task::spawn_blocking(move || {
        // Loading the world reads and decodes its maps: off the async threads, like the episode.
        let world = world_set.world(w, scale).map_err(|e| e.to_string())?;
        let mut planner = planner;
        let mut observer = CancelObserver(cancel);
        let p = planner.as_dyn();
        if spec.perception.degrades_maps() && !p.runs_on_degraded_maps() {
            return Err(format!(
                "planner {} reads the world's ground-truth maps and profile {} degrades them",
                p.name(),
                spec.perception.name
            ));
        }
        let mut hook = perception::hook(
            &spec.perception,
            &world,
            spec.task_id,
            task.start,
            spec.seed,
            vehicle.info().max_steer,
            1.0 / p.control_rate_hz(),
        );
        let r = sim_core::runner::run_episode_hooked(
            &world,
            &task,
            &vehicle,
            p,
            &cfg,
            &mut observer,
            hook.as_mut(),
        );
        let mut round_trips = Vec::new();
        if let AnyPlanner::Remote(p) = &mut planner {
            p.finish(r.outcome.as_str(), r.reason);
            round_trips = std::mem::take(&mut p.round_trips);
        }
        Ok::<_, String>((r, round_trips))
    })
    .await;
    let (result, round_trips) = joined.map_err(|e| format!("episode thread failed: {e}"))??;
    if process.is_some() {
        // Give the process a moment to flush what it printed about the episode's end.
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let planner_log = match &process {
        Some(p) => p.output.lock().map(|l| l.text()).unwrap_or_default(),
        None => log.lock().map(|l| l.text()).unwrap_or_default(),
    };
    if let Some(p) = process {
        p.stop().await;
    }
    Ok(FinishedEpisode {
        result,
        planner_log,
        planner_identity: identity,
        wall_time_s: t0.elapsed().as_secs_f64(),
        round_trips,
    })
}

/// How starting an episode's planner went: ready (with the process the worker started for it), or failed (the
/// planner's fault: the episode ends as a planner failure).
enum Started {
    Ready(AnyPlanner, String, Option<exec::PlannerProcess>),
    Failed(FinishedEpisode),
}

/// Makes a built-in, connects to an endpoint, or starts an exec or image planner and connects to it. `Err`: the
/// worker cannot run it.
async fn start_planner(
    set: &TaskSet,
    spec: &EpisodeSpec,
    deadline: Duration,
    planner_startup: Duration,
    log: &SharedLog,
    t0: Instant,
) -> Result<Started, EpisodeError> {
    use pb::planner_ref::Kind;
    let kind = spec
        .planner
        .kind
        .clone()
        .ok_or_else(|| "lease without a planner".to_string())?;
    Ok(match kind {
        Kind::Builtin(name) => match registry::Builtin::resolve(&name, None) {
            Ok(b) => {
                let weights = b
                    .weights_version()
                    .map(|v| format!(", {v}"))
                    .unwrap_or_default();
                Started::Ready(
                    AnyPlanner::Builtin(b.make()),
                    format!("builtin:{name} ({SIM_VERSION}{weights})"),
                    None,
                )
            }
            Err(e) => {
                return Err(format!("this worker cannot run builtin planner `{name}`: {e}").into())
            }
        },
        Kind::Endpoint(url) => {
            let identity = format!("endpoint:{url}");
            match RemotePlanner::connect(&url, deadline, Duration::from_secs(5)).await {
                Ok(mut p) => {
                    p.set_log(log.clone());
                    p.set_episode_context(set.version(), spec.seed);
                    p.set_perception(&spec.perception.identity());
                    Started::Ready(AnyPlanner::Remote(Box::new(p)), identity, None)
                }
                Err(e) => {
                    // A planner that answered wrongly is at fault for what it said, not unreachable.
                    let reason = match e {
                        PlannerError::Timeout(_) | PlannerError::Protocol(_) => e.reason(),
                        _ => EndReason::PlannerUnreachable,
                    };
                    Started::Failed(failed(reason, &e, String::new(), identity, t0))
                }
            }
        }
        Kind::Exec(_) | Kind::Image(_) => {
            let (argv, identity) = match kind_ref(&spec.planner) {
                Some(Kind::Image(image)) => exec::image_command(image).await?,
                Some(Kind::Exec(e)) => (e.argv.clone(), exec::exec_identity(&e.argv)),
                _ => {
                    return Err(EpisodeError::Infrastructure(
                        "unsupported planner kind".into(),
                    ))
                }
            };
            let started = exec::start(
                &argv,
                matches!(kind_ref(&spec.planner), Some(Kind::Image(_))),
                identity.clone(),
                deadline,
                planner_startup,
                spec.containment,
            );
            match started.await {
                Ok((proc_, mut p)) => {
                    p.set_log(proc_.output.clone());
                    p.set_episode_context(set.version(), spec.seed);
                    p.set_perception(&spec.perception.identity());
                    Started::Ready(AnyPlanner::Remote(Box::new(p)), identity, Some(proc_))
                }
                Err((e, text)) => Started::Failed(failed(e.reason(), &e, text, identity, t0)),
            }
        }
    })
}
