//! The store's text columns read back typed: outcome, reason and metrics are stored as they always were, an episode
//! reads them back as values, a reason stored before reasons were checked reads as its outcome's own, and corrupt
//! metrics are a clear error naming the episode (not a panic, not a silently zeroed row).

mod common;
use common::*;
use contracts::EndReason;
use sqlx::Row;
use vb_store::*;

#[tokio::test]
async fn stored_text_reads_back_typed() -> anyhow::Result<()> {
    for url in backends("typed-rows").await? {
        let store = Store::open(&url).await?;
        let id = store
            .create_submission(&new_submission("a"), &episodes(3), 0.0)
            .await?;
        let w = store
            .register_worker("w", 3, "sim-core test", "tk-w", 1.0)
            .await?;
        let l = store.lease(&w, 3, 60.0, true, 2.0).await?;
        for (lease, outcome) in l.iter().zip(["success", "rollover", "stuck"]) {
            store.report(&w, &result(lease, outcome), 3.0).await?;
        }
        // The stored text is what the store has always written.
        let pool = sqlx::AnyPool::connect(&url).await?;
        let rows = sqlx::query(
            "SELECT task_id, outcome, reason, metrics_json FROM episodes ORDER BY task_id",
        )
        .fetch_all(&pool)
        .await?;
        let text = |i: usize, c: &str| -> anyhow::Result<String> { Ok(rows[i].try_get(c)?) };
        assert_eq!(
            (text(1, "task_id")?, text(1, "outcome")?, text(1, "reason")?),
            ("w001-t1".into(), "rollover".into(), "rollover".into()),
            "{url}"
        );
        assert_eq!(text(1, "metrics_json")?, serde_json::to_string(&metrics())?);
        // And it reads back typed, the metrics bit for bit.
        let eps = store.reader().episodes(&id).await?;
        assert_eq!(eps[1].task_id, "w001-t1".parse()?);
        assert_eq!(eps[1].reason, Some(EndReason::Rollover), "{url}");
        assert_eq!(eps[1].metrics, Some(metrics()), "{url}");
        // A reason stored before reasons were checked reads as its outcome's own.
        sqlx::query("UPDATE episodes SET reason = 'exploded' WHERE task_id = 'w001-t1'")
            .execute(&pool)
            .await?;
        let eps = store.reader().episodes(&id).await?;
        assert_eq!(eps[1].reason, Some(EndReason::Rollover), "{url}");
        // Corrupt metrics: the store's error, naming the episode and the column.
        sqlx::query("UPDATE episodes SET metrics_json = '{oops' WHERE task_id = 'w001-t2'")
            .execute(&pool)
            .await?;
        let e = store.reader().episodes(&id).await.unwrap_err();
        assert!(matches!(e, StoreError::Corrupt(_)), "{e}");
        let e = e.to_string();
        assert!(e.contains("w001-t2") && e.contains("metrics"), "{url}: {e}");
        pool.close().await;
    }
    Ok(())
}
