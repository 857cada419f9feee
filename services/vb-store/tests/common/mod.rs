//! Databases and values the store's tests share.

use vb_store::*;

/// Fresh, empty databases to test on: a SQLite file, and a new PostgreSQL database when a server is configured.
pub async fn backends(test: &str) -> anyhow::Result<Vec<String>> {
    let dir = std::env::temp_dir().join(format!("vb-store-test-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir)?;
    let mut urls = vec![format!("sqlite://{}", dir.join("vb.db").display())];
    match std::env::var("VB_TEST_POSTGRES_URL") {
        Ok(admin) if !admin.is_empty() => {
            sqlx::any::install_default_drivers();
            let pool = sqlx::AnyPool::connect(&admin).await?;
            // An SQL identifier: a test named `hand-backs` gets `hand_backs`.
            let name: String = test
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
                .collect();
            let db = format!("vbtest_{}_{name}", std::process::id());
            sqlx::query(&format!("DROP DATABASE IF EXISTS {db}"))
                .execute(&pool)
                .await?;
            sqlx::query(&format!("CREATE DATABASE {db}"))
                .execute(&pool)
                .await?;
            pool.close().await;
            let base = admin.rsplit_once('/').map_or(admin.as_str(), |(b, _)| b);
            urls.push(format!("{base}/{db}"));
        }
        _ => eprintln!("SKIPPED on PostgreSQL: VB_TEST_POSTGRES_URL is unset (only SQLite tested)"),
    }
    Ok(urls)
}

pub fn new_submission(name: &str) -> NewSubmission {
    NewSubmission {
        name: name.into(),
        owner: "tester".into(),
        owner_token: "tk-1".into(),
        planner: vb_store::PlannerSpec::Builtin("pid".into()),
        planner_identity: "builtin:pid".into(),
        vehicle: "hmmwv".into(),
        scale: 1.0,
        seed: 7,
        step_deadline_s: 1.0,
        task_set_version: "abc".into(),
        sim_version: "sim-core test".into(),
        perception: Default::default(),
    }
}

pub fn episodes(n: u32) -> Vec<NewEpisode> {
    (0..n)
        .map(|i| NewEpisode {
            task_id: contracts::TaskId::new(1, i),
            level: contracts::ElevationLevel::Low,
            semantics: contracts::SemanticsKind::Rigid,
            density: contracts::ObstacleDensity::Sparse,
        })
        .collect()
}

/// The metrics every test result carries.
pub fn metrics() -> contracts::EpisodeMetrics {
    contracts::EpisodeMetrics {
        steps: 1234,
        final_goal_distance: 0.1 + 0.2,
        ..Default::default()
    }
}

/// A result of `lease` with `outcome` (an episode outcome's name) and its own reason.
pub fn result(lease: &Lease, outcome: &str) -> EpisodeResultIn {
    EpisodeResultIn {
        lease_id: lease.lease_id.clone(),
        submission_id: lease.submission.id.clone(),
        task_id: lease.task_id,
        outcome: RecordedOutcome::parse(outcome).expect("an outcome"),
        reason: contracts::EndReason::parse(outcome).expect("a reason"),
        detail: String::new(),
        metrics: Some(metrics()),
        trajectory_csv: "time,x\n0,0\n".into(),
        trajectory_gz: None,
        planner_log: "hello".into(),
        sim_version: "sim-core test".into(),
        planner_identity: "builtin:pid".into(),
        wall_time_s: 0.5,
    }
}
