//! Results: a worker's report of a finished episode, and submissions finishing.

use crate::*;
use sqlx::Row;

impl Store {
    /// Records a finished episode reported by worker `worker_id`. It is taken only for an episode that worker holds
    /// the lease `r.lease_id` on; a report for an episode that already has a result is a duplicate (ignored), any
    /// other (not leased, leased to another worker or under another lease, cancelled) is rejected.
    pub async fn report(
        &self,
        worker_id: &str,
        r: &EpisodeResultIn,
        now: f64,
    ) -> Result<ReportOutcome> {
        // Compressed and encoded before the single writer's lock is taken: other writes do not wait on them.
        let blobs = crate::blobs::Compressed::of(r);
        // Metrics are stored as JSON text (an episode no worker could run has none: the empty string).
        let metrics_json = match &r.metrics {
            None => String::new(),
            Some(m) => serde_json::to_string(m)
                .map_err(|e| StoreError::Corrupt(format!("metrics of {}: {e}", r.task_id)))?,
        };
        let _w = self.write.lock().await;
        let row = sqlx::query(
            "SELECT state, lease_id, worker_id FROM episodes WHERE submission_id = $1 AND task_id = $2",
        )
        .bind(&r.submission_id)
        .bind(r.task_id.to_string())
        .fetch_optional(&self.pool)
        .await?;
        let Some(row) = row else {
            return Ok(ReportOutcome::Rejected);
        };
        let state: String = row.try_get("state")?;
        let lease: Option<String> = row.try_get("lease_id")?;
        let holder: Option<String> = row.try_get("worker_id")?;
        match state.as_str() {
            "done" => return Ok(ReportOutcome::Duplicate),
            "leased"
                if lease.as_deref() == Some(r.lease_id.as_str())
                    && holder.as_deref() == Some(worker_id) => {}
            _ => return Ok(ReportOutcome::Rejected),
        }
        // The result, its trajectory and log (compressed, in their own table) and the planner's identity land
        // together or not at all.
        let mut tx = self.pool.begin().await?;
        let n = sqlx::query(
            "UPDATE episodes SET state = 'done', outcome = $1, reason = $2, detail = $3, metrics_json = $4, \
             sim_version = $5, planner_identity = $6, wall_time_s = $7, finished_at = $8, lease_id = NULL, \
             lease_expires = NULL WHERE submission_id = $9 AND task_id = $10 AND state = 'leased' AND lease_id = $11",
        )
        .bind(r.outcome.as_str())
        .bind(r.reason.as_str())
        .bind(&r.detail)
        .bind(metrics_json)
        .bind(r.sim_version.as_str())
        .bind(&r.planner_identity)
        .bind(r.wall_time_s)
        .bind(now)
        .bind(&r.submission_id)
        .bind(r.task_id.to_string())
        .bind(&r.lease_id)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        if n == 0 {
            return Ok(ReportOutcome::Duplicate);
        }
        crate::blobs::insert(&mut tx, &r.submission_id, r.task_id, &blobs).await?;
        if !r.planner_identity.is_empty() {
            sqlx::query("UPDATE submissions SET planner_identity = $1 WHERE id = $2")
                .bind(&r.planner_identity)
                .bind(&r.submission_id)
                .execute(&mut *tx)
                .await?;
        }
        tx.commit().await?;
        self.finish_submissions(now).await?;
        Ok(ReportOutcome::Accepted)
    }

    /// Marks running submissions with nothing left to run as done.
    pub(crate) async fn finish_submissions(&self, now: f64) -> Result<()> {
        sqlx::query(
            "UPDATE submissions SET state = 'done', finished_at = $1 WHERE state IN ('queued', 'running') AND NOT EXISTS \
             (SELECT 1 FROM episodes e WHERE e.submission_id = submissions.id AND e.state IN ('queued', 'leased'))",
        )
        .bind(now)
        .execute(&self.pool)
        .await?;
        Ok(())
    }
}
