//! The leaderboard's read-only view: submissions, progress, throughput and episodes.

use crate::*;
use sqlx::Row;

impl Reader {
    /// Opens a read-only view of the store at `url` (the leaderboard run apart from the coordinator). The schema
    /// must already exist: the coordinator creates and migrates it.
    pub async fn open(url: &str) -> Result<Reader> {
        let (pool, _) = open_pool(url, 4).await?;
        Ok(Reader { pool })
    }

    pub async fn submission(&self, id: &str) -> Result<Submission> {
        let row = sqlx::query("SELECT * FROM submissions WHERE id = $1")
            .bind(id)
            .fetch_optional(&self.pool)
            .await?
            .ok_or_else(|| StoreError::UnknownSubmission(id.into()))?;
        submission_from_row(&row)
    }

    /// Every submission, newest first.
    pub async fn submissions(&self) -> Result<Vec<Submission>> {
        let rows = sqlx::query("SELECT * FROM submissions ORDER BY seq DESC")
            .fetch_all(&self.pool)
            .await?;
        rows.iter().map(submission_from_row).collect()
    }

    pub async fn progress(&self, id: &str) -> Result<Progress> {
        let sub = self.submission(id).await?;
        let r = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS total, \
             CAST(COALESCE(SUM(CASE WHEN state = 'done' THEN 1 ELSE 0 END), 0) AS BIGINT) AS finished, \
             CAST(COALESCE(SUM(CASE WHEN state = 'leased' THEN 1 ELSE 0 END), 0) AS BIGINT) AS running, \
             CAST(COALESCE(SUM(CASE WHEN state = 'queued' THEN 1 ELSE 0 END), 0) AS BIGINT) AS queued, \
             CAST(COALESCE(SUM(CASE WHEN state = 'not_run' THEN 1 ELSE 0 END), 0) AS BIGINT) AS not_run, \
             CAST(COALESCE(SUM(CASE WHEN outcome = 'success' THEN 1 ELSE 0 END), 0) AS BIGINT) AS successes \
             FROM episodes WHERE submission_id = $1",
        )
        .bind(id)
        .fetch_one(&self.pool)
        .await?;
        let get = |c: &str| -> Result<u32> { Ok(r.try_get::<i64, _>(c)? as u32) };
        let ahead = sqlx::query(
            "SELECT CAST(COUNT(DISTINCT e.submission_id) AS BIGINT) AS subs, CAST(COUNT(*) AS BIGINT) AS eps \
             FROM episodes e JOIN submissions s ON s.id = e.submission_id \
             WHERE e.state IN ('queued', 'leased') AND s.seq < $1 AND s.state IN ('queued', 'running')",
        )
        .bind(sub.seq)
        .fetch_one(&self.pool)
        .await?;
        let mut p = Progress {
            total: get("total")?,
            finished: get("finished")?,
            running: get("running")?,
            queued: get("queued")?,
            not_run: get("not_run")?,
            successes: get("successes")?,
            queue_position: ahead.try_get::<i64, _>("subs")? as u32,
            episodes_ahead: ahead.try_get::<i64, _>("eps")? as u32,
        };
        if !sub.state.is_active() {
            p.queue_position = 0;
            p.episodes_ahead = 0;
        } else {
            p.episodes_ahead += p.queued + p.running;
        }
        Ok(p)
    }

    /// Episodes finished (by any submission) since `since`, and when the first of them finished: the service's
    /// recent throughput.
    pub async fn finished_since(&self, since: f64) -> Result<FinishedSince> {
        let r = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n, MIN(finished_at) AS first, MAX(finished_at) AS last FROM episodes \
             WHERE state = 'done' AND finished_at >= $1",
        )
        .bind(since)
        .fetch_one(&self.pool)
        .await?;
        Ok(FinishedSince {
            n: r.try_get::<i64, _>("n")? as u64,
            first: r.try_get("first")?,
            last: r.try_get("last")?,
        })
    }

    /// Every episode of a submission, in task order.
    pub async fn episodes(&self, submission_id: &str) -> Result<Vec<EpisodeRecord>> {
        let rows = sqlx::query(&format!(
            "SELECT {EPISODE_COLUMNS} FROM episodes WHERE submission_id = $1 ORDER BY ord"
        ))
        .bind(submission_id)
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(episode_from_row).collect()
    }

    /// `limit` episodes of a submission from position `offset`, in task order (a page of its episode table).
    pub async fn episodes_range(
        &self,
        submission_id: &str,
        offset: usize,
        limit: usize,
    ) -> Result<Vec<EpisodeRecord>> {
        let rows = sqlx::query(&format!(
            "SELECT {EPISODE_COLUMNS} FROM episodes WHERE submission_id = $1 ORDER BY ord LIMIT $2 OFFSET $3"
        ))
        .bind(submission_id)
        .bind(limit as i64)
        .bind(offset as i64)
        .fetch_all(&self.pool)
        .await?;
        rows.iter().map(episode_from_row).collect()
    }

    pub async fn episode_detail(
        &self,
        submission_id: &str,
        task: contracts::TaskId,
    ) -> Result<EpisodeDetail> {
        let task_id = task.to_string();
        let row = sqlx::query(&format!(
            "SELECT {EPISODE_COLUMNS} FROM episodes WHERE submission_id = $1 AND task_id = $2"
        ))
        .bind(submission_id)
        .bind(&task_id)
        .fetch_optional(&self.pool)
        .await?
        .ok_or_else(|| StoreError::UnknownEpisode {
            submission: submission_id.into(),
            task,
        })?;
        let (trajectory_csv, planner_log) =
            crate::blobs::read(&self.pool, submission_id, task).await?;
        Ok(EpisodeDetail {
            record: episode_from_row(&row)?,
            trajectory_csv,
            planner_log,
        })
    }
}

/// Episodes finished in a window: how many, and when the first and the last of them finished.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FinishedSince {
    pub n: u64,
    pub first: Option<f64>,
    pub last: Option<f64>,
}

/// Fewest finished episodes a throughput estimate is made from.
pub const MIN_RATE_EPISODES: u64 = 8;

impl FinishedSince {
    /// Episodes per second between the first and the last finish: `n - 1` intervals over their span (counting `n`
    /// over the span from the first finish overestimates the rate just after it). `None` until
    /// [`MIN_RATE_EPISODES`] have finished over a positive span, so a first burst gives no wild ETA.
    pub fn rate(&self) -> Option<f64> {
        let (first, last) = (self.first?, self.last?);
        (self.n >= MIN_RATE_EPISODES && last > first).then(|| (self.n - 1) as f64 / (last - first))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Episodes finishing every 50 ms (20 a second) from t = 100 s, polled every 0.37 s: no estimate before
    /// [`MIN_RATE_EPISODES`], then the rate exactly and an ETA for 2000 episodes that counts down with the clock
    /// (within one episode's interval of the truth) instead of jumping.
    #[test]
    fn the_rate_is_steady_from_the_first_estimate() {
        let period = 0.05;
        let total = 2000.0;
        let mut known = 0;
        for poll in 1..200 {
            let t = 100.0 + poll as f64 * 0.37;
            let n = ((t - 100.0) / period).floor() as u64 + 1;
            let w = FinishedSince {
                n,
                first: Some(100.0),
                last: Some(100.0 + (n - 1) as f64 * period),
            };
            match w.rate() {
                None => assert!(n < MIN_RATE_EPISODES, "no rate at {n} episodes"),
                Some(rate) => {
                    known += 1;
                    assert!((rate - 1.0 / period).abs() < 1e-6, "rate {rate} at {n}");
                    let eta = (total - n as f64) / rate;
                    let truth = 100.0 + (total - 1.0) * period - t;
                    assert!(
                        (eta - truth).abs() <= period + 1e-9,
                        "ETA {eta} s, truly {truth} s"
                    );
                }
            }
        }
        assert!(known > 190);
        // One episode, or several at one instant, give no rate.
        let burst = FinishedSince {
            n: 20,
            first: Some(5.0),
            last: Some(5.0),
        };
        assert_eq!(burst.rate(), None);
    }
}
