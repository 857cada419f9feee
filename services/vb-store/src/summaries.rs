//! Stored aggregates of submissions (`submission_summaries`): written by the coordinator as results arrive and when
//! a submission ends, read by the leaderboard in one row per submission.

use crate::*;
use contracts::Catalog;
use serde::{Deserialize, Serialize};
use sqlx::Row;

/// A submission's stored aggregates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StoredSummary {
    /// Finished episodes the summary covers.
    pub finished: u32,
    pub successes: u32,
    pub summary: results::summary::Summary,
    pub updated_at: f64,
}

fn stored_from_row(r: &sqlx::any::AnyRow) -> Result<Option<StoredSummary>> {
    let Some(json) = r.try_get::<Option<String>, _>("summary_json")? else {
        return Ok(None);
    };
    Ok(Some(StoredSummary {
        finished: r.try_get::<i64, _>("m_finished")? as u32,
        successes: r.try_get::<i64, _>("m_successes")? as u32,
        summary: serde_json::from_str(&json)
            .map_err(|e| StoreError::Corrupt(format!("stored summary: {e}")))?,
        updated_at: r.try_get("m_updated_at")?,
    }))
}

const SUCCESS: RecordedOutcome = RecordedOutcome::Episode(contracts::Outcome::Success);

const SUMMARY_COLUMNS: &str =
    "m.finished AS m_finished, m.successes AS m_successes, m.summary_json, \
     m.updated_at AS m_updated_at";

impl Store {
    /// Recomputes and stores a submission's aggregates from its finished episodes (`catalog`: the task set served,
    /// for the matched density contrasts). O(one submission's episodes).
    pub async fn refresh_summary(
        &self,
        id: &str,
        catalog: Option<&Catalog>,
        now: f64,
    ) -> Result<()> {
        let reader = self.reader();
        let sub = reader.submission(id).await?;
        let eps = reader.episodes(id).await?;
        let summary = aggregate::summary_of(&sub, &eps, catalog)?;
        let finished = eps.iter().filter(|e| e.state == EpisodeState::Done).count() as i64;
        let successes = eps
            .iter()
            .filter(|e| e.state == EpisodeState::Done && e.outcome == Some(SUCCESS))
            .count() as i64;
        let json = serde_json::to_string(&summary)
            .map_err(|e| StoreError::Corrupt(format!("summary: {e}")))?;
        let _w = self.write.lock().await;
        sqlx::query(
            "INSERT INTO submission_summaries (submission_id, finished, successes, summary_json, updated_at) \
             VALUES ($1, $2, $3, $4, $5) ON CONFLICT (submission_id) DO UPDATE SET finished = excluded.finished, \
             successes = excluded.successes, summary_json = excluded.summary_json, updated_at = excluded.updated_at",
        )
        .bind(id)
        .bind(finished)
        .bind(successes)
        .bind(json)
        .bind(now)
        .execute(&self.pool)
        .await?;
        Ok(())
    }

    /// Submissions whose stored aggregates are missing or cover fewer finished episodes than they have.
    pub async fn stale_summaries(&self) -> Result<Vec<String>> {
        let rows = sqlx::query(
            "SELECT s.id FROM submissions s \
             LEFT JOIN submission_summaries m ON m.submission_id = s.id \
             LEFT JOIN (SELECT submission_id, CAST(COUNT(*) AS BIGINT) AS n FROM episodes WHERE state = 'done' \
                        GROUP BY submission_id) d ON d.submission_id = s.id \
             WHERE m.submission_id IS NULL OR m.finished <> COALESCE(d.n, 0) ORDER BY s.seq",
        )
        .fetch_all(&self.pool)
        .await?;
        rows.iter()
            .map(|r| r.try_get::<String, _>("id").map_err(StoreError::from))
            .collect()
    }
}

impl Reader {
    /// Every submission with its stored aggregates (None until the coordinator has written them), newest first:
    /// one row per submission.
    pub async fn board(&self) -> Result<Vec<(Submission, Option<StoredSummary>)>> {
        let rows = sqlx::query(&format!(
            "SELECT s.*, {SUMMARY_COLUMNS} FROM submissions s \
             LEFT JOIN submission_summaries m ON m.submission_id = s.id ORDER BY s.seq DESC"
        ))
        .fetch_all(&self.pool)
        .await?;
        rows.iter()
            .map(|r| Ok((submission_from_row(r)?, stored_from_row(r)?)))
            .collect()
    }

    /// One submission's stored aggregates, if written.
    pub async fn stored_summary(&self, id: &str) -> Result<Option<StoredSummary>> {
        let row = sqlx::query(&format!(
            "SELECT {SUMMARY_COLUMNS} FROM submission_summaries m WHERE m.submission_id = $1"
        ))
        .bind(id)
        .fetch_optional(&self.pool)
        .await?;
        match row {
            Some(r) => stored_from_row(&r),
            None => Ok(None),
        }
    }
}
