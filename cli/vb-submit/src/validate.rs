//! `vb-submit validate` (the `validate` feature): a planner run on one short task locally, through the worker's own
//! code, before 1000 episodes are queued. The only part of `vb-submit` that links the worker and the simulator.

use crate::{PlannerRef, SubmitError};
use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

/// What `validate` found.
#[derive(Clone, Debug)]
pub struct Validation {
    pub ok: bool,
    pub outcome: String,
    pub reason: String,
    pub detail: String,
    pub control_steps: usize,
    pub round_trip_p50_ms: f64,
    pub round_trip_p99_ms: f64,
    pub round_trip_max_ms: f64,
    pub planner_log: String,
    /// Why the planner ran without namespaces of its own (a worker here would refuse exec planners), if it did.
    pub unisolated: Option<String>,
}

/// Runs `planner` on one short task locally, through the same code the workers use, and says whether it follows
/// the protocol (connects, answers every step in time with valid actions). Driving well is not required.
pub async fn validate(
    planner: PlannerRef,
    task_dir: &Path,
    task_id: &str,
    max_time: f64,
    step_deadline_s: f64,
    planner_user: Option<&str>,
    perception: &str,
) -> Result<Validation, SubmitError> {
    let perception =
        vb_worker::perception::Profile::resolve(perception, |p| std::fs::read_to_string(p))
            .map_err(|e| SubmitError::Usage(e.to_string()))?;
    let planner_user = planner_user
        .map(vb_worker::sandbox::PlannerUser::lookup)
        .transpose()
        .map_err(SubmitError::Usage)?;
    let set =
        Arc::new(tasks::TaskSet::load(task_dir).map_err(|e| SubmitError::Usage(e.to_string()))?);
    let task_id: contracts::TaskId = task_id
        .parse()
        .map_err(|_| SubmitError::Usage(format!("bad task id `{task_id}` (like w001-t0)")))?;
    // The planner is the user's own, run on their machine: without namespaces here it still runs, and says so.
    let (containment, unisolated) = match vb_worker::sandbox::Containment::probe(planner_user).await
    {
        Ok(c) => (c, None),
        Err(why) => (
            vb_worker::sandbox::Containment {
                namespaces: false,
                user: planner_user,
            },
            Some(why),
        ),
    };
    let spec = vb_worker::EpisodeSpec {
        task_id,
        planner,
        vehicle: "hmmwv".into(),
        scale: 1.0,
        seed: 0,
        step_deadline_s,
        max_time: Some(max_time),
        containment,
        perception,
    };
    let run = vb_worker::run_leased(
        set,
        spec,
        Arc::new(AtomicBool::new(false)),
        Duration::from_secs(30),
    )
    .await
    .map_err(|e| SubmitError::Usage(e.to_string()))?;
    let mut rt = run.round_trips.clone();
    rt.sort_by(f64::total_cmp);
    let r = &run.result;
    Ok(Validation {
        ok: r.outcome != sim_core::episode::Outcome::PlannerFailure,
        outcome: r.outcome.as_str().into(),
        reason: r.reason.to_string(),
        detail: r.detail.clone(),
        control_steps: rt.len(),
        round_trip_p50_ms: rt.get(rt.len() / 2).copied().unwrap_or(0.0) * 1e3,
        round_trip_p99_ms: rt.get(rt.len() * 99 / 100).copied().unwrap_or(0.0) * 1e3,
        round_trip_max_ms: rt.last().copied().unwrap_or(0.0) * 1e3,
        planner_log: run.planner_log,
        unisolated,
    })
}
