//! The lease loop of a worker (`run_worker`): register, lease (a slot's worth ahead), heartbeat, run each episode
//! ([`crate::run_leased`]), report with retries, and on shutdown drain: finish within the limit, hand back the rest.

use crate::startup::{Client, PlannerPolicy};
use crate::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tasks::TaskSet;
use vb_proto::v1 as pb;
use vb_proto::v1::episode_report::Unscored;
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
        unscored: None,
    }
}

/// Delivers a report, retrying (with backoff) while the coordinator is unreachable, so a coordinator restart loses
/// nothing. Gives up only on a definite refusal, or after `give_up`.
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

/// Runs a worker until `shutdown` turns true.
pub async fn run_worker(
    cfg: WorkerConfig,
    mut shutdown: tokio::sync::watch::Receiver<bool>,
) -> Result<(), WorkerError> {
    let set = Arc::new(TaskSet::load(&cfg.task_dir)?);
    let mut client = startup::connect(&cfg)?;
    let slots = cfg.slots.max(1);
    let Some(reg) = startup::register(&mut client, &cfg, slots, &shutdown).await? else {
        return Ok(());
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
    let period = Duration::from_secs_f64(reg.heartbeat_s.clamp(0.1, 60.0));
    let heartbeats = heartbeat(client.clone(), active.clone(), worker_id.clone(), period);
    let caps = startup::capabilities(&cfg).await;
    let slot = Slots {
        set,
        worker_id: worker_id.clone(),
        active: active.clone(),
        freed: Arc::new(tokio::sync::Notify::new()),
        permits: Arc::new(tokio::sync::Semaphore::new(slots)),
        unstarted: Arc::new(AtomicUsize::new(0)),
        reporting: Arc::new(AtomicUsize::new(0)),
        policy: caps.policy,
    };
    let mut backoff = Duration::from_millis(100);
    loop {
        if *shutdown.borrow() {
            drain(&mut client, &worker_id, &active, &slot.unstarted, cfg.drain).await;
            let reporting = slot.reporting.clone();
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
                    runs_exec_planners: caps.runs_exec,
                    runs_image_planners: caps.runs_images,
                })
                .await
            {
                Ok(r) => {
                    backoff = Duration::from_millis(100);
                    for lease in r.into_inner().leases {
                        got += 1;
                        slot.start(client.clone(), lease, shutdown.clone());
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
                _ = slot.freed.notified() => {}
                _ = tokio::time::sleep(Duration::from_millis(200)) => {}
                _ = shutdown.changed() => {}
            }
        }
    }
}

/// Renews the leases of running episodes every `period` (while they drain at shutdown too), and abandons those the
/// coordinator no longer gives this worker.
fn heartbeat(
    mut client: Client,
    active: Active,
    worker_id: String,
    period: Duration,
) -> tokio::task::JoinHandle<()> {
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
}

/// What every leased episode of this worker shares: the task set, the running episodes, the slots.
#[derive(Clone)]
struct Slots {
    set: Arc<TaskSet>,
    worker_id: String,
    active: Active,
    /// Signalled whenever an episode ends, so the loop leases for the freed slot at once.
    freed: Arc<tokio::sync::Notify>,
    permits: Arc<tokio::sync::Semaphore>,
    /// Leased episodes handed back unstarted by a stopping worker (for its last log line).
    unstarted: Arc<AtomicUsize>,
    /// Reports of ended episodes still being delivered (a stopping worker waits for them).
    reporting: Arc<AtomicUsize>,
    policy: PlannerPolicy,
}

impl Slots {
    /// Runs `lease` in a slot of its own once one is free, unless the worker stops first (then the episode goes back
    /// unstarted), and delivers its report.
    fn start(
        &self,
        mut client: Client,
        lease: pb::EpisodeLease,
        mut stopping: tokio::sync::watch::Receiver<bool>,
    ) {
        let flag = Arc::new(AtomicBool::new(false));
        if let Ok(mut a) = self.active.lock() {
            a.insert(lease.lease_id.clone(), flag.clone());
        }
        let s = self.clone();
        tokio::spawn(async move {
            let permit = tokio::select! {
                p = s.permits.clone().acquire_owned() => p.ok(),
                _ = stopping.wait_for(|s| *s) => None,
            };
            let report = match permit {
                Some(_slot) if !*stopping.borrow() => {
                    run_lease(
                        s.set.clone(),
                        &s.worker_id,
                        lease.clone(),
                        flag.clone(),
                        s.policy,
                    )
                    .await
                }
                _ => {
                    s.unstarted.fetch_add(1, Ordering::SeqCst);
                    Some(handed_back(&s.worker_id, &lease.lease_id))
                }
            };
            // The slot is free while the report travels.
            s.reporting.fetch_add(1, Ordering::SeqCst);
            if let Ok(mut a) = s.active.lock() {
                a.remove(&lease.lease_id);
            }
            s.freed.notify_one();
            if let Some(r) = report {
                deliver(&mut client, r, Duration::from_secs(600)).await;
            }
            s.reporting.fetch_sub(1, Ordering::SeqCst);
        });
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
        unscored: Some(Unscored::HandedBack(true)),
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
        unscored: Some(Unscored::InfrastructureFailure(true)),
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
    let perception = match crate::lease_profile(&lease.perception, &lease.perception_params) {
        Ok(p) => p,
        Err(e) => return Some(infra(e)),
    };
    let spec = EpisodeSpec {
        task_id,
        perception,
        planner: lease.planner.clone().unwrap_or_default(),
        vehicle: lease.vehicle.as_str().into(),
        scale: lease.scale,
        seed: lease.seed,
        step_deadline_s: lease.step_deadline_s,
        max_time: None,
        containment,
    };
    match run_leased(set, spec, cancel.clone(), startup).await {
        Err(EpisodeError::Infrastructure(why)) => Some(infra(why)),
        // Another worker may run it (the coordinator leases this submission to this one no more).
        Err(EpisodeError::CannotRun(why)) => Some(pb::EpisodeReport {
            unscored: Some(Unscored::CannotRun(true)),
            ..infra(why)
        }),
        // The lease was taken back (expired, finished elsewhere, or the submission was cancelled).
        Ok(_) if cancel.load(Ordering::Relaxed) => None,
        Ok(run) => Some(report(worker_id, &lease, &run, set_version)),
    }
}
