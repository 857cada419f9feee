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
pub mod remote;
pub mod sandbox;
pub mod sim_service;
// The client's TLS setup is the protocol crate's (vb-submit uses it without the worker).
pub use vb_proto::tls;

use remote::{PlannerLog, RemotePlanner, SharedLog};
use sim_core::episode::{EpisodeConfig, EpisodeResult, Outcome};
use sim_core::planner::{Action, Planner, PlannerError, VehicleState};
use sim_core::runner::EpisodeObserver;
use std::collections::HashMap;
use std::io::Write;
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tasks::TaskSet;
use tonic::transport::Channel;
use vb_proto::v1 as pb;
use vb_proto::v1::worker_pool_client::WorkerPoolClient;

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

/// Parses `wNNN-tK` ([`contracts::TaskId`]'s one spelling) into (world, task index).
pub fn parse_task_id(id: &str) -> Option<(u32, u32)> {
    let t: contracts::TaskId = id.parse().ok()?;
    Some((t.world, t.index))
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
    pub task_id: String,
    pub planner: pb::PlannerRef,
    pub vehicle: String,
    pub scale: f64,
    pub seed: u64,
    pub step_deadline_s: f64,
    /// Overrides the default 60 s time limit (validation runs are short).
    pub max_time: Option<f64>,
    /// Run exec planners as this (unprivileged) user instead of the worker's.
    pub planner_user: Option<sandbox::PlannerUser>,
}

/// A finished episode, ready to report.
#[derive(Clone, Debug)]
pub struct EpisodeRun {
    pub result: EpisodeResult,
    pub planner_log: String,
    pub planner_identity: String,
    pub wall_time_s: f64,
    /// Round-trip times of the remote planner's control steps, s (empty for built-in planners).
    pub round_trips: Vec<f64>,
}

fn failed(
    reason: &str,
    e: &PlannerError,
    log: String,
    identity: String,
    t0: Instant,
) -> EpisodeRun {
    EpisodeRun {
        result: EpisodeResult {
            outcome: Outcome::PlannerFailure,
            reason: reason.into(),
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

/// Runs one episode. `Err` means the worker could not run it (not the planner's fault): the coordinator re-queues
/// it. Planner failures are an `Ok` run with outcome `planner_failure`.
pub async fn run_episode(
    set: Arc<TaskSet>,
    spec: EpisodeSpec,
    cancel: Arc<AtomicBool>,
    planner_startup: Duration,
) -> Result<EpisodeRun, String> {
    let t0 = Instant::now();
    let (w, t) =
        parse_task_id(&spec.task_id).ok_or_else(|| format!("bad task id `{}`", spec.task_id))?;
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
    use pb::planner_ref::Kind;
    let kind = spec
        .planner
        .kind
        .clone()
        .ok_or_else(|| "lease without a planner".to_string())?;
    let log: SharedLog = Arc::new(Mutex::new(PlannerLog::default()));
    let mut process = None;
    let (planner, identity) = match kind {
        Kind::Builtin(name) => match baselines::by_name(&name) {
            Some(p) => (
                AnyPlanner::Builtin(p),
                format!("builtin:{name} ({SIM_VERSION})"),
            ),
            None => return Err(format!("this worker has no builtin planner `{name}`")),
        },
        Kind::Endpoint(url) => {
            let identity = format!("endpoint:{url}");
            match RemotePlanner::connect(&url, deadline, Duration::from_secs(5)).await {
                Ok(mut p) => {
                    p.set_log(log.clone());
                    p.set_episode_context(set.version(), spec.seed);
                    (AnyPlanner::Remote(Box::new(p)), identity)
                }
                Err(e) => {
                    let reason = if matches!(e, PlannerError::Timeout(_)) {
                        "planner_timeout"
                    } else {
                        "planner_unreachable"
                    };
                    return Ok(failed(reason, &e, String::new(), identity, t0));
                }
            }
        }
        Kind::Exec(_) | Kind::Image(_) => {
            let (argv, identity) = match kind_ref(&spec.planner) {
                Some(Kind::Image(image)) => exec::image_command(image).await?,
                Some(Kind::Exec(e)) => (e.argv.clone(), exec::exec_identity(&e.argv)),
                _ => return Err("unsupported planner kind".into()),
            };
            let user = spec
                .planner_user
                .filter(|_| matches!(kind_ref(&spec.planner), Some(Kind::Exec(_))));
            match exec::start(&argv, identity.clone(), deadline, planner_startup, user).await {
                Ok((proc_, mut p)) => {
                    p.set_log(proc_.output.clone());
                    p.set_episode_context(set.version(), spec.seed);
                    process = Some(proc_);
                    (AnyPlanner::Remote(Box::new(p)), identity)
                }
                Err((e, text)) => return Ok(failed(e.reason(), &e, text, identity, t0)),
            }
        }
    };
    let scale = spec.scale;
    let world_set = set.clone();
    let joined = tokio::task::spawn_blocking(move || {
        // Loading the world reads and decodes its maps: off the async threads, like the episode.
        let world = world_set.world(w, scale).map_err(|e| e.to_string())?;
        let mut planner = planner;
        let mut observer = CancelObserver(cancel);
        let r = sim_core::runner::run_episode_observed(
            &world,
            &task,
            &vehicle,
            planner.as_dyn(),
            &cfg,
            &mut observer,
        );
        let mut round_trips = Vec::new();
        if let AnyPlanner::Remote(p) = &mut planner {
            p.finish(r.outcome.as_str(), &r.reason);
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
    Ok(EpisodeRun {
        result,
        planner_log,
        planner_identity: identity,
        wall_time_s: t0.elapsed().as_secs_f64(),
        round_trips,
    })
}

fn report(
    worker_id: &str,
    lease: &pb::EpisodeLease,
    run: &EpisodeRun,
    task_set_version: &str,
) -> pb::EpisodeReport {
    pb::EpisodeReport {
        task_set_version: task_set_version.into(),
        worker_id: worker_id.into(),
        lease_id: lease.lease_id.clone(),
        submission_id: lease.submission_id.clone(),
        task_id: lease.task_id.clone(),
        outcome: run.result.outcome.as_str().into(),
        reason: run.result.reason.clone(),
        detail: run.result.detail.clone(),
        metrics_json: serde_json::to_vec(&run.result.metrics).unwrap_or_default(),
        trajectory: trajectory_gzip(&run.result),
        planner_log: run.planner_log.clone(),
        sim_version: SIM_VERSION.into(),
        planner_identity: run.planner_identity.clone(),
        wall_time_s: run.wall_time_s,
        infrastructure_failure: false,
        handed_back: false,
    }
}

/// Delivers a report, retrying (with backoff) while the coordinator is unreachable, so a coordinator restart loses
/// nothing. Gives up only on a definite refusal, or after `give_up`.
/// Sends the worker token with every call.
#[derive(Clone)]
struct Auth(tonic::metadata::MetadataValue<tonic::metadata::Ascii>);

impl tonic::service::Interceptor for Auth {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        req.metadata_mut().insert("authorization", self.0.clone());
        Ok(req)
    }
}

type Client = WorkerPoolClient<tonic::service::interceptor::InterceptedService<Channel, Auth>>;

async fn deliver(client: &mut Client, r: pb::EpisodeReport, give_up: Duration) {
    let t0 = Instant::now();
    let mut backoff = Duration::from_millis(100);
    loop {
        match client.report_result(r.clone()).await {
            Ok(_) => return,
            Err(s)
                if s.code() == tonic::Code::InvalidArgument
                    || s.code() == tonic::Code::ResourceExhausted =>
            {
                tracing::warn!(
                    submission = %r.submission_id,
                    task = %r.task_id,
                    error = %s.message(),
                    "the coordinator refused a report"
                );
                return;
            }
            Err(s) => {
                if t0.elapsed() > give_up {
                    tracing::error!(
                        submission = %r.submission_id,
                        task = %r.task_id,
                        after_s = give_up.as_secs_f64(),
                        error = %s.message(),
                        "giving up on a report"
                    );
                    return;
                }
                tokio::time::sleep(backoff).await;
                backoff = (backoff * 2).min(Duration::from_secs(2));
            }
        }
    }
}

type Active = Arc<Mutex<HashMap<String, Arc<AtomicBool>>>>;

/// How this worker runs planners.
#[derive(Clone, Copy, Debug)]
struct PlannerPolicy {
    /// How long a started planner process may take to serve.
    startup: Duration,
    /// Whether it runs exec and image planners (the coordinator then leases it none: `runs_exec_planners`).
    allow_exec: bool,
    /// The user exec planners run as.
    user: Option<sandbox::PlannerUser>,
}

/// Runs a worker until `shutdown` turns true.
pub async fn run_worker(
    cfg: WorkerConfig,
    mut shutdown: tokio::sync::watch::Receiver<bool>,
) -> Result<(), WorkerError> {
    let set = Arc::new(TaskSet::load(&cfg.task_dir)?);
    let channel = tls::endpoint(&cfg.coordinator, cfg.tls_ca.as_deref())
        .map_err(|e| WorkerError::Address(cfg.coordinator.clone(), e))?
        .connect_timeout(Duration::from_secs(2))
        .tcp_nodelay(true)
        .connect_lazy();
    let auth = format!("Bearer {}", cfg.token.trim())
        .parse()
        .map_err(|_| WorkerError::Refused("the worker token is not valid header text".into()))?;
    let mut client = WorkerPoolClient::with_interceptor(channel, Auth(auth))
        .max_encoding_message_size(crate::remote::MAX_WORKER_MESSAGE);
    let slots = cfg.slots.max(1);
    // Register, waiting for the coordinator if it is not up yet.
    let reg = loop {
        if *shutdown.borrow() {
            return Ok(());
        }
        match client
            .register(pb::RegisterRequest {
                worker_name: cfg.name.clone(),
                slots: slots as u32,
                sim_version: SIM_VERSION.into(),
            })
            .await
        {
            Ok(r) => break r.into_inner(),
            Err(s)
                if matches!(
                    s.code(),
                    tonic::Code::FailedPrecondition
                        | tonic::Code::InvalidArgument
                        | tonic::Code::Unauthenticated
                        | tonic::Code::PermissionDenied
                ) =>
            {
                return Err(WorkerError::Refused(s.message().into()))
            }
            Err(_) => tokio::time::sleep(Duration::from_millis(300)).await,
        }
    };
    let worker_id = reg.worker_id.clone();
    tracing::info!(
        name = %cfg.name,
        worker = %worker_id,
        slots,
        lease_s = reg.lease_s,
        "worker registered"
    );
    let active: Active = Arc::new(Mutex::new(HashMap::new()));
    // Heartbeats: renew the leases of running episodes (while they drain at shutdown too); abandon those the
    // coordinator no longer gives us.
    let heartbeats = {
        let mut client = client.clone();
        let active = active.clone();
        let worker_id = worker_id.clone();
        let period = Duration::from_secs_f64(reg.heartbeat_s.clamp(0.1, 60.0));
        tokio::spawn(async move {
            loop {
                tokio::time::sleep(period).await;
                let ids: Vec<String> = active
                    .lock()
                    .map(|a| a.keys().cloned().collect())
                    .unwrap_or_default();
                if ids.is_empty() {
                    continue;
                }
                if let Ok(r) = client
                    .heartbeat(pb::HeartbeatRequest {
                        worker_id: worker_id.clone(),
                        lease_ids: ids,
                    })
                    .await
                {
                    if let Ok(a) = active.lock() {
                        for id in r.into_inner().expired_lease_ids {
                            if let Some(flag) = a.get(&id) {
                                flag.store(true, Ordering::Relaxed);
                            }
                        }
                    }
                }
            }
        })
    };
    let policy = PlannerPolicy {
        startup: Duration::from_secs_f64(cfg.planner_startup_s.max(1.0)),
        allow_exec: cfg.allow_exec,
        user: cfg.planner_user,
    };
    let allow_exec = policy.allow_exec;
    // Image planners only where Docker runs: other workers leave image submissions to those that can.
    let runs_images = allow_exec
        && match exec::docker_available().await {
            Ok(()) => true,
            Err(why) => {
                tracing::info!(reason = %why, "image planners are left to other workers");
                false
            }
        };
    // Signalled whenever an episode ends, so the loop leases for the freed slot at once.
    let freed = Arc::new(tokio::sync::Notify::new());
    let permits = Arc::new(tokio::sync::Semaphore::new(slots));
    // Leased episodes handed back unstarted by a stopping worker (for its last log line).
    let unstarted = Arc::new(AtomicUsize::new(0));
    // Reports of ended episodes still being delivered (a stopping worker waits for them).
    let reporting = Arc::new(AtomicUsize::new(0));
    let mut backoff = Duration::from_millis(100);
    loop {
        if *shutdown.borrow() {
            drain(&mut client, &worker_id, &active, &unstarted, cfg.drain).await;
            let t0 = Instant::now();
            while reporting.load(Ordering::SeqCst) > 0 && t0.elapsed() < REPORTS_AT_EXIT {
                tokio::time::sleep(Duration::from_millis(20)).await;
            }
            heartbeats.abort();
            return Ok(());
        }
        // Up to `slots` episodes run; as many more wait leased here, so a freed slot starts the next episode at
        // once instead of after a lease round trip.
        let held = active.lock().map(|a| a.len()).unwrap_or(2 * slots);
        let free = (2 * slots).saturating_sub(held);
        let mut got = 0;
        if free > 0 {
            match client
                .lease(pb::LeaseRequest {
                    worker_id: worker_id.clone(),
                    max: free as u32,
                    runs_exec_planners: allow_exec,
                    runs_image_planners: runs_images,
                })
                .await
            {
                Ok(r) => {
                    backoff = Duration::from_millis(100);
                    for lease in r.into_inner().leases {
                        got += 1;
                        let flag = Arc::new(AtomicBool::new(false));
                        if let Ok(mut a) = active.lock() {
                            a.insert(lease.lease_id.clone(), flag.clone());
                        }
                        let set = set.clone();
                        let mut client = client.clone();
                        let active = active.clone();
                        let worker_id = worker_id.clone();
                        let freed = freed.clone();
                        let reporting = reporting.clone();
                        let permits = permits.clone();
                        let unstarted = unstarted.clone();
                        let mut stopping = shutdown.clone();
                        tokio::spawn(async move {
                            // A slot, unless the worker stops first (then the episode goes back unstarted).
                            let permit = tokio::select! {
                                p = permits.acquire_owned() => p.ok(),
                                _ = stopping.wait_for(|s| *s) => None,
                            };
                            let report = match permit {
                                Some(_slot) if !*stopping.borrow() => {
                                    run_lease(set, &worker_id, lease.clone(), flag.clone(), policy)
                                        .await
                                }
                                _ => {
                                    unstarted.fetch_add(1, Ordering::SeqCst);
                                    Some(handed_back(&worker_id, &lease.lease_id))
                                }
                            };
                            // The slot is free while the report travels.
                            reporting.fetch_add(1, Ordering::SeqCst);
                            if let Ok(mut a) = active.lock() {
                                a.remove(&lease.lease_id);
                            }
                            freed.notify_one();
                            if let Some(r) = report {
                                deliver(&mut client, r, Duration::from_secs(600)).await;
                            }
                            reporting.fetch_sub(1, Ordering::SeqCst);
                        });
                    }
                }
                Err(s) => {
                    if s.code() == tonic::Code::NotFound {
                        tracing::warn!(
                            worker = %worker_id,
                            error = %s.message(),
                            "the coordinator does not know this worker"
                        );
                    }
                    tokio::time::sleep(backoff).await;
                    backoff = (backoff * 2).min(Duration::from_secs(2));
                    continue;
                }
            }
        }
        if got == 0 {
            // Wait for a slot to free (at once when one does) or, with free slots, for work to be queued.
            tokio::select! {
                _ = freed.notified() => {}
                _ = tokio::time::sleep(Duration::from_millis(200)) => {}
                _ = shutdown.changed() => {}
            }
        }
    }
}

/// Episodes running now.
fn running(active: &Active) -> usize {
    active.lock().map(|a| a.len()).unwrap_or(0)
}

/// Waits until no episode runs, or `limit` has passed.
async fn wait_idle(active: &Active, limit: Duration) {
    let t0 = Instant::now();
    while running(active) > 0 && t0.elapsed() < limit {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// A stopping worker takes no new leases. Its running episodes get `limit` to finish (their results are reported as
/// usual, heartbeats keep their leases); the others are stopped, their planners cleaned up, and handed back to the
/// queue, so they neither wait for their leases to expire nor use up an attempt.
async fn drain(
    client: &mut Client,
    worker_id: &str,
    active: &Active,
    unstarted: &AtomicUsize,
    limit: Duration,
) {
    let n = running(active);
    if n == 0 {
        return;
    }
    tracing::info!(
        running = n,
        drain_s = limit.as_secs_f64(),
        "stopping: running episodes may finish, the rest are handed back"
    );
    wait_idle(active, limit).await;
    let left: Vec<(String, Arc<AtomicBool>)> = active
        .lock()
        .map(|a| a.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
        .unwrap_or_default();
    for (lease_id, stop) in &left {
        stop.store(true, Ordering::Relaxed);
        let back = handed_back(worker_id, lease_id);
        let why = match tokio::time::timeout(HAND_BACK_TIMEOUT, client.report_result(back)).await {
            Ok(Ok(_)) => continue,
            Ok(Err(s)) => s.message().to_string(),
            Err(_) => "the coordinator did not answer".to_string(),
        };
        tracing::warn!(
            lease = %lease_id,
            reason = %why,
            "could not hand back an episode (its lease will expire)"
        );
    }
    // The stopped episodes end their planners (process groups, containers) before the worker exits.
    wait_idle(active, HAND_BACK_TIMEOUT).await;
    let unstarted = unstarted.load(Ordering::SeqCst);
    tracing::info!(
        finished = n.saturating_sub(left.len() + unstarted),
        handed_back = left.len() + unstarted,
        "worker stopped"
    );
}

/// The report that hands an unfinished episode back to the queue.
fn handed_back(worker_id: &str, lease_id: &str) -> pb::EpisodeReport {
    pb::EpisodeReport {
        worker_id: worker_id.into(),
        lease_id: lease_id.into(),
        handed_back: true,
        sim_version: SIM_VERSION.into(),
        ..Default::default()
    }
}

/// How long a stopping worker waits for the reports of its ended episodes to be delivered.
const REPORTS_AT_EXIT: Duration = Duration::from_secs(10);

/// How long a stopping worker waits for the coordinator to take one handed-back lease, and for its stopped episodes
/// to clean up.
const HAND_BACK_TIMEOUT: Duration = Duration::from_secs(3);

/// Runs a leased episode; the report to deliver (none when the lease was taken back).
async fn run_lease(
    set: Arc<TaskSet>,
    worker_id: &str,
    lease: pb::EpisodeLease,
    cancel: Arc<AtomicBool>,
    policy: PlannerPolicy,
) -> Option<pb::EpisodeReport> {
    let PlannerPolicy {
        startup,
        user: planner_user,
        ..
    } = policy;
    let infra = |detail: String| pb::EpisodeReport {
        worker_id: worker_id.into(),
        lease_id: lease.lease_id.clone(),
        submission_id: lease.submission_id.clone(),
        task_id: lease.task_id.clone(),
        outcome: "error".into(),
        reason: "infrastructure".into(),
        detail,
        sim_version: SIM_VERSION.into(),
        infrastructure_failure: true,
        ..Default::default()
    };
    if lease.task_set_version != set.version() {
        let msg = format!(
            "worker has task set {} but the submission needs {}",
            set.version(),
            lease.task_set_version
        );
        return Some(infra(msg));
    }
    let set_version = set.version().to_string();
    let set_version = set_version.as_str();
    let spec = EpisodeSpec {
        task_id: lease.task_id.clone(),
        planner: lease.planner.clone().unwrap_or_default(),
        vehicle: lease.vehicle.clone(),
        scale: lease.scale,
        seed: lease.seed,
        step_deadline_s: lease.step_deadline_s,
        max_time: None,
        planner_user,
    };
    match run_episode(set, spec, cancel.clone(), startup).await {
        Err(msg) => Some(infra(msg)),
        // The lease was taken back (expired, finished elsewhere, or the submission was cancelled).
        Ok(_) if cancel.load(Ordering::Relaxed) => None,
        Ok(run) => Some(report(worker_id, &lease, &run, set_version)),
    }
}
