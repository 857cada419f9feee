//! The store at scale: trajectories and logs live compressed outside the episodes table (and an older store's are
//! moved there when it opens), and each submission's aggregates are stored, kept current and read one row per
//! submission. SQLite always, PostgreSQL when `VB_TEST_POSTGRES_URL` names a server.

mod common;

use common::*;
use contracts::TaskId;
use sqlx::Row;
use vb_store::*;

#[tokio::test]
async fn trajectories_and_logs_live_compressed_outside_the_episodes_table() -> anyhow::Result<()> {
    for url in backends("blobs").await? {
        let store = Store::open(&url).await?;
        let id = store
            .create_submission(&new_submission("a"), &episodes(1), 0.0)
            .await?;
        let w = store
            .register_worker("w", 1, "sim-core test", "tk-w", 0.0)
            .await?;
        let l = store.lease(&w, 1, 30.0, true, 1.0).await?;
        let mut r = result(&l[0], "success");
        r.trajectory_csv = "time,x\n".to_string() + &"0.1,2.5\n".repeat(5000);
        r.planner_log = "log line\n".repeat(100);
        store.report(&w, &r, 2.0).await?;
        let d = store
            .reader()
            .episode_detail(&id, TaskId::new(1, 0))
            .await?;
        assert_eq!(d.trajectory_csv, r.trajectory_csv, "{url}");
        assert_eq!(d.planner_log, r.planner_log, "{url}");
        // Nothing inline; the stored bytes are compressed.
        sqlx::any::install_default_drivers();
        let pool = sqlx::AnyPool::connect(&url).await?;
        let inline = sqlx::query("SELECT trajectory_csv FROM episodes WHERE submission_id = $1")
            .bind(&id)
            .fetch_one(&pool)
            .await?;
        assert_eq!(inline.try_get::<Option<String>, _>("trajectory_csv")?, None);
        let blob = sqlx::query("SELECT trajectory_gz FROM episode_blobs WHERE submission_id = $1")
            .bind(&id)
            .fetch_one(&pool)
            .await?;
        let bytes: Vec<u8> = blob.try_get("trajectory_gz")?;
        assert!(
            bytes.len() * 10 < r.trajectory_csv.len(),
            "{url}: {} compressed bytes of {}",
            bytes.len(),
            r.trajectory_csv.len()
        );
    }
    Ok(())
}

#[tokio::test]
async fn an_older_stores_inline_trajectories_are_moved_when_it_opens() -> anyhow::Result<()> {
    for url in backends("move").await? {
        let id = {
            let store = Store::open(&url).await?;
            store
                .create_submission(&new_submission("old"), &episodes(3), 0.0)
                .await?
        };
        // What a store written before the move holds: results with their trajectories and logs inline.
        sqlx::any::install_default_drivers();
        let pool = sqlx::AnyPool::connect(&url).await?;
        for t in 0..3 {
            sqlx::query(
                "UPDATE episodes SET state = 'done', outcome = 'success', trajectory_csv = $1, planner_log = $2 \
                 WHERE submission_id = $3 AND task_id = $4",
            )
            .bind(format!("time,x\n{t},1\n"))
            .bind(format!("log {t}"))
            .bind(&id)
            .bind(format!("w001-t{t}"))
            .execute(&pool)
            .await?;
        }
        // Readable as they are, by a reader of the not yet reopened store.
        let d = Reader::open(&url)
            .await?
            .episode_detail(&id, TaskId::new(1, 1))
            .await?;
        assert_eq!(
            (d.trajectory_csv.as_str(), d.planner_log.as_str()),
            ("time,x\n1,1\n", "log 1")
        );
        // The coordinator reopens it: everything moved, nothing left inline, nothing changed for readers.
        let store = Store::open(&url).await?;
        let left = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM episodes WHERE trajectory_csv IS NOT NULL OR planner_log IS NOT NULL",
        )
        .fetch_one(&pool)
        .await?;
        assert_eq!(left.try_get::<i64, _>("n")?, 0, "{url}");
        for t in 0..3 {
            let d = store
                .reader()
                .episode_detail(&id, TaskId::new(1, t))
                .await?;
            assert_eq!(d.trajectory_csv, format!("time,x\n{t},1\n"), "{url}");
            assert_eq!(d.planner_log, format!("log {t}"), "{url}");
        }
    }
    Ok(())
}

#[tokio::test]
async fn summaries_are_stored_kept_current_and_read_one_row_per_submission() -> anyhow::Result<()> {
    for url in backends("summaries").await? {
        let store = Store::open(&url).await?;
        let a = store
            .create_submission(&new_submission("a"), &episodes(4), 0.0)
            .await?;
        let b = store
            .create_submission(&new_submission("b"), &episodes(2), 0.0)
            .await?;
        assert_eq!(store.reader().submission(&a).await?.tasks, 4);
        // Nothing stored yet: both are stale.
        assert_eq!(
            store.stale_summaries().await?,
            vec![a.clone(), b.clone()],
            "{url}"
        );
        store.refresh_summary(&a, None, 1.0).await?;
        store.refresh_summary(&b, None, 1.0).await?;
        assert!(store.stale_summaries().await?.is_empty(), "{url}");
        let w = store
            .register_worker("w", 8, "sim-core test", "tk-w", 0.0)
            .await?;
        let leases = store.lease(&w, 3, 30.0, true, 2.0).await?;
        assert!(leases.iter().all(|l| l.submission.id == a));
        for (l, outcome) in leases.iter().zip(["success", "stuck", "success"]) {
            store.report(&w, &result(l, outcome), 3.0).await?;
        }
        // Results arrived: a is stale until refreshed, b is not.
        assert_eq!(store.stale_summaries().await?, vec![a.clone()], "{url}");
        store.refresh_summary(&a, None, 4.0).await?;
        let board = store.reader().board().await?;
        assert_eq!(board.len(), 2);
        let (sub, m) = board
            .iter()
            .find(|(s, _)| s.id == a)
            .expect("a on the board");
        let m = m.as_ref().expect("a's summary");
        assert_eq!((sub.tasks, m.finished, m.successes), (4, 3, 2), "{url}");
        assert_eq!(m.summary.overall.episodes, 3);
        assert!((m.summary.overall.success_rate - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(m.summary.planner, "a");
        assert_eq!(m.updated_at, 4.0);
        assert_eq!(store.reader().stored_summary(&a).await?.as_ref(), Some(m));
        assert_eq!(store.reader().stored_summary("sub-none").await?, None);
        // The operators' counts.
        let c = store.reader().counts(5.0).await?;
        assert!(c.episodes_by_state.contains(&("done".into(), 3)), "{c:?}");
        assert!(c.episodes_by_state.contains(&("queued".into(), 3)), "{c:?}");
        assert_eq!(c.outcomes, vec![("stuck".into(), 1), ("success".into(), 2)]);
        assert_eq!(c.finished_last_minute, 3);
        assert_eq!((c.workers_live, c.slots_live), (1, 8));
        assert_eq!(store.reader().counts(500.0).await?.workers_live, 0);
        // A page of episodes, in task order.
        let page = store.reader().episodes_range(&a, 1, 2).await?;
        let ids: Vec<String> = page.iter().map(|e| e.task_id.to_string()).collect();
        assert_eq!(ids, ["w001-t1", "w001-t2"], "{url}");
    }
    Ok(())
}
