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

    // The full run's page shows its 1000 episodes 100 at a time.
    let full = by_name("full");
    let eps = vb_leaderboard::public::episodes(&store.reader(), &full.submission.id)
        .await
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    assert_eq!(eps.len(), 1000);
    let rows = |html: &str| {
        html.matches("<tr><td class=\"l\"><a href=\"/submissions/")
            .count()
    };
    let link = |n: usize| format!("/submissions/{}?page={n}", full.submission.id);
    let at = |n: usize| {
        let (page, from) = vb_leaderboard::pages::submission::page_offset(n, eps.len());
        let shown = &eps[from..(from + 100).min(eps.len())];
        vb_leaderboard::pages::submission::page(full, shown, page, from)
    };
    let first = at(1);
    assert_eq!(rows(&first), 100);
    assert!(first.contains("Episodes 1-100 of 1000 (page 1 of 10)."));
    assert!(first.contains(&link(2)) && !first.contains("rel=\"prev\""));
    let second = at(2);
    assert!(second.contains("Episodes 101-200 of 1000"));
    assert!(
        second.contains(&eps[100].task_id) && !second.contains(&format!(">{}<", eps[99].task_id))
    );
    // Past the end shows the last page.
    let last = at(99);
    assert!(last.contains("Episodes 901-1000 of 1000 (page 10 of 10)."));
    assert!(!last.contains("rel=\"next\""));
    Ok(())
}

/// `vb leaderboard-static` ranks the same way: a partial evaluation is listed, unranked, after the full one.
#[test]
fn the_static_board_ranks_only_full_evaluations() {
    use vb_leaderboard::pages::board::{standalone, Evaluation};
    let eval = |name: &str, episodes: usize, rate: f64| {
        let mut summary = eval::summary::summarise(&[]);
        summary.overall.episodes = episodes;
        summary.overall.success_rate = rate;
        Evaluation {
            name: name.into(),
            summary,
            full_tasks: Some(1000),
        }
    };
    let page = standalone(&[eval("partial-run", 330, 0.9), eval("full-run", 1000, 0.4)]);
    let at = |s: &str| page.find(s).unwrap_or_else(|| panic!("{s} missing"));
    assert!(at("full-run") < at("partial-run"));
    assert!(
        page.contains("<tr><td>1</td><td class=\"l\">full-run"),
        "{page}"
    );
    assert!(
        page.contains("<tr><td>-</td><td class=\"l\">partial-run"),
        "{page}"
    );
}
