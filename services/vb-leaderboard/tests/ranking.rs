//! The ranking: only complete runs of the current task set and simulator get a rank; the others are listed apart
//! with why; two submissions compare paired.

mod common;

use vb_store::*;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn only_comparable_complete_runs_are_ranked() -> anyhow::Result<()> {
    let dir = std::env::temp_dir().join(format!("vb-rank-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let store = Store::open(&format!("sqlite://{}", dir.join("vb.db").display())).await?;
    let (set, served) = common::committed()?;
    let metrics = contracts::EpisodeMetrics::default();
    let w = store.register_worker("w", 64, "s", "tw", 0.0).await?;
    // A full run with some failures, a 2-task run that succeeded on both, and a full run on another simulator
    // that succeeded everywhere.
    let mut ids = Vec::new();
    let full_set = set.world_ids().len() * 10;
    for (name, tasks, succeed_every, sim) in [
        ("full", full_set, 3, common::SIM_VERSION),
        ("lucky", 2, 1, common::SIM_VERSION),
        ("old-sim", full_set, 1, "sim-core 0.0.1 r0"),
    ] {
        let episodes: Vec<NewEpisode> = set
            .world_ids()
            .iter()
            .flat_map(|&w| (0..10).map(move |t| (w, t)))
            .take(tasks)
            .map(|(w, t)| NewEpisode {
                task_id: contracts::TaskId::new(w, t),
                level: contracts::ElevationLevel::Low,
                semantics: contracts::SemanticsKind::Rigid,
                density: contracts::ObstacleDensity::Sparse,
            })
            .collect();
        let sub = NewSubmission {
            name: name.into(),
            owner: "o".into(),
            owner_token: "t".into(),
            planner: vb_store::PlannerSpec::Builtin("pid".into()),
            planner_identity: "builtin:pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            step_deadline_s: 1.0,
            task_set_version: set.version().into(),
            sim_version: sim.into(),
            perception: Default::default(),
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
                    contracts::Outcome::Success
                } else {
                    contracts::Outcome::Stuck
                };
                k += 1;
                let r = EpisodeResultIn {
                    lease_id: l.lease_id.clone(),
                    submission_id: l.submission.id.clone(),
                    task_id: l.task_id,
                    outcome: contracts::RecordedOutcome::Episode(outcome),
                    reason: contracts::RecordedOutcome::Episode(outcome).plain_reason(),
                    detail: String::new(),
                    metrics: Some(metrics.clone()),
                    trajectory_csv: String::new(),
                    trajectory_gz: None,
                    planner_log: String::new(),
                    sim_version: sim.into(),
                    planner_identity: String::new(),
                    wall_time_s: 0.0,
                };
                store.report(&w, &r, 3.0).await?;
            }
        }
        ids.push(id);
    }
    for id in &ids {
        store
            .refresh_summary(id, Some(&served.catalog), 4.0)
            .await?;
    }
    let lb =
        vb_leaderboard::Leaderboard::new(store.reader(), common::SIM_VERSION, Some(served.clone()));
    let ranking = lb.ranked().await.map_err(|e| anyhow::anyhow!("{e:?}"))?;
    assert_eq!(ranking.reference.sim_version, common::SIM_VERSION);
    assert_eq!(ranking.reference.tasks as usize, full_set);
    let ranked = &ranking.entries;
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
    use vb_leaderboard::ranking::Unranked;
    assert_eq!(
        by_name("lucky").unranked,
        Some(Unranked::Partial {
            finished: 2,
            tasks: full_set as u32
        })
    );
    assert_eq!(by_name("lucky").coverage, 2.0 / full_set as f64);
    let old = by_name("old-sim");
    assert_eq!(old.rank, None, "a run on another simulator is not ranked");
    assert_eq!(
        old.unranked,
        Some(Unranked::OtherSimulator {
            sim_version: "sim-core 0.0.1 r0".into()
        })
    );
    assert_eq!(old.summary.overall.success_rate, 1.0);
    // The board: the ranked table, then the runs listed apart with why and their coverage.
    let board = vb_leaderboard::pages::board::index(ranked, &ranking.reference, &[]);
    let (ranked_table, apart_table) = board.split_once("Listed apart").expect("runs listed apart");
    assert!(ranked_table.contains(">full</a>") && !ranked_table.contains(">lucky</a>"));
    assert!(
        apart_table.contains("partial: 2 of 1000 tasks</td><td>2 / 1000 (0.2%)"),
        "{apart_table}"
    );
    assert!(
        apart_table.contains("other simulator (sim-core 0.0.1 r0)</td><td>1000 / 1000 (100.0%)")
    );

    // Pairwise: the full run against the other-simulator one on all 1000 tasks, as vb compare pairs them.
    let c = lb
        .compare(&by_name("full").submission.id, &old.submission.id)
        .await
        .map_err(|e| anyhow::anyhow!("{e:?}"))?;
    let full_successes = (0..full_set).filter(|k| k % 3 == 0).count();
    assert_eq!(c.overall.paired_tasks, full_set);
    assert_eq!(
        (c.overall.a_only, c.overall.b_only),
        (0, full_set - full_successes)
    );
    assert_eq!(c.overall.success_b, 1.0);
    assert!(c.overall.mcnemar_p < 1e-4 && c.overall.significant);
    assert!(
        c.notes.iter().any(|n| n.contains("simulator")),
        "{:?}",
        c.notes
    );
    assert_eq!(c.by_level.len(), 1, "every task here is `low`");
    let page = vb_leaderboard::pages::compare::page(&c);
    assert!(
        page.contains("p &#60; 0.0001 *") || page.contains("p < 0.0001 *"),
        "{page}"
    );

    // The full run's page shows its 1000 episodes 100 at a time.
    let full = by_name("full");
    let eps = vb_leaderboard::public::episodes(&store.reader(), &full.submission)
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
        vb_leaderboard::pages::submission::page(full, shown, page, from, &[], None)
    };
    let first = at(1);
    assert_eq!(rows(&first), 100);
    assert!(first.contains("Episodes 1-100 of 1000 (page 1 of 10)."));
    assert!(first.contains(&link(2)) && !first.contains("rel=\"prev\""));
    let second = at(2);
    assert!(second.contains("Episodes 101-200 of 1000"));
    assert!(
        second.contains(&eps[100].task_id.to_string())
            && !second.contains(&format!(">{}<", eps[99].task_id))
    );
    // Past the end shows the last page.
    let last = at(99);
    assert!(last.contains("Episodes 901-1000 of 1000 (page 10 of 10)."));
    assert!(!last.contains("rel=\"next\""));
    Ok(())
}

/// `vb leaderboard-static` ranks the same way: a partial evaluation and one under the release's rules are listed,
/// unranked, after the full one.
#[test]
fn the_static_board_ranks_only_full_evaluations() {
    use vb_leaderboard::pages::board::{standalone, Evaluation};
    use vb_leaderboard::ranking::Reference;
    let eval = |name: &str, episodes: usize, rate: f64| {
        let mut summary = results::summary::summarise(&[]);
        summary.overall.episodes = episodes;
        summary.overall.success_rate = rate;
        summary.task_set_version = "set".into();
        summary.sim_version = common::SIM_VERSION.into();
        Evaluation {
            name: name.into(),
            summary,
        }
    };
    let mut release = eval("release-rules", 1000, 0.95);
    release.summary.rules = contracts::Rules::Release;
    let evals = [
        eval("partial-run", 330, 0.9),
        eval("full-run", 1000, 0.4),
        release,
    ];
    // Without a reference the most common set among the evaluations is ranked, full at its largest run.
    for reference in [
        Some(Reference::current("set", 1000, common::SIM_VERSION)),
        None,
    ] {
        let page = standalone(&evals, common::SIM_VERSION, reference);
        assert!(
            page.contains("<tr><td>1</td><td class=\"l\">full-run"),
            "{page}"
        );
        assert!(page.contains("release-rules</td><td class=\"l\"></td><td class=\"l\"></td><td class=\"l why\">release rules"), "{page}");
    }
    let page = standalone(
        &evals,
        common::SIM_VERSION,
        Some(Reference::current("set", 1000, common::SIM_VERSION)),
    );
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
