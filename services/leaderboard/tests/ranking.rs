//! The ranking: only complete runs get a rank.

use vb_store::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn only_complete_runs_are_ranked() -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("vb-rank-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let store = Store::open(&format!("sqlite://{}", dir.join("vb.db").display())).await?;
    let set = tasks::TaskSet::load(&tasks::TaskSet::default_dir())?;
    let metrics = serde_json::to_string(&sim_core::episode::EpisodeMetrics::default())?;
    let w = store.register_worker("w", 64, "s", "tw", 0.0).await?;
    // A full run with some failures, and a 2-task run that succeeded on both.
    let mut ids = Vec::new();
    for (name, tasks, succeed_every) in [("full", set.world_ids().len() * 10, 3), ("lucky", 2, 1)] {
        let episodes: Vec<NewEpisode> = set
            .world_ids()
            .iter()
            .flat_map(|&w| (0..10).map(move |t| (w, t)))
            .take(tasks)
            .map(|(w, t)| NewEpisode {
                task_id: format!("w{w:03}-t{t}"),
                world_id: w,
                task_index: t,
                level: "low".into(),
                semantics: "rigid".into(),
                density: "sparse".into(),
            })
            .collect();
        let sub = NewSubmission {
            name: name.into(),
            owner: "o".into(),
            owner_token: "t".into(),
            planner_kind: "builtin".into(),
            planner_spec: "pid".into(),
            planner_identity: "builtin:pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            step_deadline_s: 1.0,
            task_set_version: set.version().into(),
            sim_version: "s".into(),
        };
        let id = store.create_submission(&sub, &episodes, 1.0).await?;
        let mut k = 0;
        loop {
            let leases = store.lease(&w, 64, 30.0, true, 2.0).await?;
            if leases.is_empty() {
                break;
            }
            for l in leases {
                let outcome = if k % succeed_every == 0 {
                    "success"
                } else {
                    "stuck"
                };
                k += 1;
                let r = EpisodeResultIn {
                    lease_id: l.lease_id.clone(),
                    submission_id: l.submission.id.clone(),
                    task_id: l.task_id.clone(),
                    outcome: outcome.into(),
                    reason: outcome.into(),
                    metrics_json: metrics.clone(),
                    sim_version: "s".into(),
                    ..Default::default()
                };
                store.report(&w, &r, 3.0).await?;
            }
        }
        ids.push(id);
    }
    let lb = vb_leaderboard::Leaderboard::new(store.reader(), Some(set));
    let ranked = lb.ranked().await.map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let by_name = |n: &str| ranked.iter().find(|e| e.submission.name == n).unwrap();
    assert_eq!(by_name("full").rank, Some(1));
    assert_eq!(
        by_name("lucky").rank,
        None,
        "two lucky episodes do not top the board"
    );
    assert!(
        by_name("lucky").summary.overall.success_rate
            > by_name("full").summary.overall.success_rate
    );
    assert_eq!(ranked[0].submission.name, "full");
    Ok(())
}
