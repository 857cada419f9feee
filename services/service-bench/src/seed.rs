//! Throw-away stores for benchmarks (`vb bench leaderboard`): finished submissions written through the store's own
//! API, as the coordinator fills a store.

use contracts::Catalog;
use vb_store::{EpisodeResultIn, NewEpisode, NewSubmission, Store, StoreError};

/// Seeds `submissions` finished submissions of `episodes` episodes each (at most one per task of `catalog`'s set, outcomes mixed, a
/// trajectory of `trajectory_rows` rows and a short log per episode), each with its stored aggregates. Returns
/// their ids.
pub async fn seed(
    store: &Store,
    catalog: &Catalog,
    submissions: usize,
    episodes: usize,
    trajectory_rows: usize,
) -> Result<Vec<String>, StoreError> {
    // At most one episode per task of the catalog's set (task ids are unique within a submission).
    let tasks: Vec<NewEpisode> = catalog
        .all_tasks()
        .into_iter()
        .take(episodes)
        .filter_map(|id| NewEpisode::of(catalog, id))
        .collect();
    let mut trajectory = String::from("time,x,y,z,roll,pitch,yaw,speed,throttle,steering,brake\n");
    for k in 0..trajectory_rows {
        let t = k as f64 * 0.1;
        trajectory += &format!(
            "{t:.2},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.3},0.8,{:.3},0\n",
            10.0 + 2.0 * t,
            20.0 + 0.5 * t,
            1.0 + (t * 0.3).sin(),
            0.05 * (t * 0.7).sin(),
            0.04 * (t * 0.5).cos(),
            0.3,
            3.0 + (t * 0.2).sin(),
            0.1 * (t * 0.9).sin()
        );
    }
    let metrics = contracts::EpisodeMetrics {
        time: 42.0,
        path_length: 80.0,
        ..Default::default()
    };
    let worker = store
        .register_worker("bench", 256, "bench", "bench-token", 0.0)
        .await?;
    use contracts::Outcome::{Rollover, Stuck, Success, Timeout};
    let outcomes = [Success, Stuck, Success, Rollover, Timeout, Success];
    let mut ids = Vec::new();
    for s in 0..submissions {
        let sub = NewSubmission {
            name: format!("bench-{s:03}"),
            owner: "bench".into(),
            owner_token: "bench".into(),
            planner: vb_store::PlannerSpec::Builtin("pid".into()),
            planner_identity: "builtin:pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: s as u64,
            step_deadline_s: 1.0,
            task_set_version: catalog.task_set_version.clone(),
            sim_version: "bench".into(),
            perception: Default::default(),
        };
        let t = 1.0 + s as f64;
        let id = store.create_submission(&sub, &tasks, t).await?;
        let mut k = s;
        loop {
            let leases = store.lease(&worker, 256, 600.0, true, t).await?;
            if leases.is_empty() {
                break;
            }
            for l in leases {
                let outcome = outcomes[k % outcomes.len()];
                k += 1;
                let r = EpisodeResultIn {
                    lease_id: l.lease_id,
                    submission_id: l.submission.id,
                    task_id: l.task_id,
                    outcome: contracts::RecordedOutcome::Episode(outcome),
                    reason: contracts::RecordedOutcome::Episode(outcome).plain_reason(),
                    detail: String::new(),
                    metrics: Some(metrics.clone()),
                    trajectory_csv: trajectory.clone(),
                    trajectory_gz: None,
                    planner_log: "planner: ready\n".into(),
                    sim_version: "bench".into(),
                    planner_identity: "builtin:pid".into(),
                    wall_time_s: 0.05,
                };
                store.report(&worker, &r, t).await?;
            }
        }
        store.refresh_summary(&id, Some(catalog), t + 0.5).await?;
        ids.push(id);
    }
    Ok(ids)
}
