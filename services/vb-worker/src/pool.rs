//! The lease loop of a worker (`run_worker`): register, lease (a slot's worth ahead), heartbeat, run each episode
//! ([`crate::run_episode`]), report with retries, and on shutdown drain: finish within the limit, hand back the rest.

use crate::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tasks::TaskSet;
use tonic::transport::Channel;
use vb_proto::v1 as pb;
use vb_proto::v1::worker_pool_client::WorkerPoolClient;
use vb_proto::ProtoEnum;

fn report(
    worker_id: &str,
    lease: &pb::EpisodeLease,
    run: &FinishedEpisode,
    task_set_version: &str,
) -> pb::EpisodeReport {
    pb::EpisodeReport {
        task_set_version: task_set_version.into(),
        worker_id: worker_id.into(),
        lease_id: lease.lease_id.clone(),
        submission_id: lease.submission_id.clone(),
        task_id: lease.task_id.clone(),
        outcome: pb::Outcome::from(run.result.outcome).into(),
        reason: run.result.reason.wire(),
        detail: run.result.detail.clone(),
        metrics: Some((&run.result.metrics).into()),
        trajectory: trajectory_gzip(&run.result),
        planner_log: run.planner_log.clone(),
        sim_version: SIM_VERSION.into(),
        planner_identity: run.planner_identity.clone(),
        wall_time_s: run.wall_time_s,
        infrastructure_failure: false,
        handed_back: false,
        cannot_run: false,
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
    /// How exec planners are contained.
    containment: sandbox::Containment,
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
    // Exec planners only where they can be given namespaces of their own: a worker that cannot contain them says so
    // and leaves them to workers that can, rather than promising an isolation it does not give.
    let (containment, runs_exec) = if cfg.allow_exec {
        match sandbox::Containment::probe(cfg.planner_user).await {
            Ok(c) => (c, true),
            Err(why) => {
                tracing::warn!(reason = %why, "exec planners are refused by this worker (left to other workers)");
                (sandbox::Containment::default(), false)
            }
        }
    } else {
        (sandbox::Containment::default(), false)
    };
    let policy = PlannerPolicy {
        startup: Duration::from_secs_f64(cfg.planner_startup_s.max(1.0)),
        containment,
    };
    // Image planners only where Docker runs: other workers leave image submissions to those that can.
    let runs_images = cfg.allow_exec
        && match exec::docker_available().await {
            Ok(()) => true,
            Err(why) => {
                tracing::info!(reason = %why, "image planners are left to other workers");
                false
            }
        };
    // What planners of this machine's dead workers left (a watchdog removes it unless the machine went down or the
    // watchdog was killed): never anything of a worker not proven dead.
    if cfg.allow_exec {
        let swept = sandbox::reaper::sweep(runs_images).await;
        if swept != sandbox::reaper::Swept::default() {
            tracing::info!(
                containers = swept.containers,
                dirs = swept.dirs,
                "removed what planners of dead workers left"
            );
        }
    }
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
            wait_until(REPORTS_AT_EXIT, || reporting.load(Ordering::SeqCst) == 0).await;
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
                    runs_exec_planners: runs_exec,
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

/// Waits until `done()` holds, or `limit` has passed (only a stopping worker waits like this).
async fn wait_until(limit: Duration, done: impl Fn() -> bool) {
    let t0 = Instant::now();
    while !done() && t0.elapsed() < limit {
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
    wait_until(limit, || running(active) == 0).await;
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
    wait_until(HAND_BACK_TIMEOUT, || running(active) == 0).await;
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
        containment,
    } = policy;
    let infra = |detail: String| pb::EpisodeReport {
        worker_id: worker_id.into(),
        lease_id: lease.lease_id.clone(),
        submission_id: lease.submission_id.clone(),
        task_id: lease.task_id.clone(),
        outcome: contracts::RecordedOutcome::InfrastructureError.wire(),
        reason: contracts::EndReason::Infrastructure.wire(),
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
    let task_id = match lease.task_id.parse::<contracts::TaskId>() {
        Ok(t) => t,
        Err(e) => return Some(infra(e.to_string())),
    };
    let spec = EpisodeSpec {
        task_id,
        planner: lease.planner.clone().unwrap_or_default(),
        vehicle: lease.vehicle.clone(),
        scale: lease.scale,
        seed: lease.seed,
        step_deadline_s: lease.step_deadline_s,
        max_time: None,
        containment,
    };
    match run_episode(set, spec, cancel.clone(), startup).await {
        Err(EpisodeError::Infrastructure(why)) => Some(infra(why)),
        // Another worker may run it (the coordinator leases this submission to this one no more).
        Err(EpisodeError::CannotRun(why)) => Some(pb::EpisodeReport {
            cannot_run: true,
            ..infra(why)
        }),
        // The lease was taken back (expired, finished elsewhere, or the submission was cancelled).
        Ok(_) if cancel.load(Ordering::Relaxed) => None,
        Ok(run) => Some(report(worker_id, &lease, &run, set_version)),
    }
}
