//! Counts for operators (the leaderboard's `/metrics`): submissions and episodes by state, recent throughput and
//! live workers.

use crate::*;
use sqlx::Row;

/// What `/metrics` reports, read in a few small queries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Counts {
    pub submissions_by_state: Vec<(String, u64)>,
    pub episodes_by_state: Vec<(String, u64)>,
    /// Finished episodes by outcome.
    pub outcomes: Vec<(String, u64)>,
    /// Finished episodes that did not succeed, by reason (stuck, rollover, planner_crash, infrastructure, ...).
    pub failures_by_reason: Vec<(String, u64)>,
    /// Episodes finished in the last minute.
    pub finished_last_minute: u64,
    /// Workers heard from in the last minute, and their slots.
    pub workers_live: u64,
    pub slots_live: u64,
    /// Leases that ended without a result (expired or released), ever.
    pub lease_drops: u64,
}

impl Reader {
    /// The store's counts at time `now` (seconds since the Unix epoch).
    pub async fn counts(&self, now: f64) -> Result<Counts> {
        let grouped = |sql: &'static str| async move {
            let rows = sqlx::query(sql).fetch_all(&self.pool).await?;
            rows.iter()
                .map(|r| {
                    Ok((
                        r.try_get::<String, _>("k")?,
                        r.try_get::<i64, _>("n")? as u64,
                    ))
                })
                .collect::<Result<Vec<_>>>()
        };
        let submissions_by_state = grouped(
            "SELECT state AS k, CAST(COUNT(*) AS BIGINT) AS n FROM submissions GROUP BY state ORDER BY state",
        )
        .await?;
        let episodes_by_state =
            grouped("SELECT state AS k, CAST(COUNT(*) AS BIGINT) AS n FROM episodes GROUP BY state ORDER BY state")
                .await?;
        let outcomes = grouped(
            "SELECT outcome AS k, CAST(COUNT(*) AS BIGINT) AS n FROM episodes WHERE state = 'done' \
             AND outcome IS NOT NULL GROUP BY outcome ORDER BY outcome",
        )
        .await?;
        let failures_by_reason = grouped(
            "SELECT reason AS k, CAST(COUNT(*) AS BIGINT) AS n FROM episodes WHERE state = 'done' \
             AND outcome IS NOT NULL AND outcome <> 'success' AND reason IS NOT NULL GROUP BY reason ORDER BY reason",
        )
        .await?;
        let finished_last_minute = self.finished_since(now - 60.0).await?.n;
        let w = sqlx::query(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n, CAST(COALESCE(SUM(slots), 0) AS BIGINT) AS slots FROM workers \
             WHERE last_seen >= $1",
        )
        .bind(now - 60.0)
        .fetch_one(&self.pool)
        .await?;
        let drops = sqlx::query("SELECT CAST(COUNT(*) AS BIGINT) AS n FROM lease_drops")
            .fetch_one(&self.pool)
            .await?;
        Ok(Counts {
            lease_drops: drops.try_get::<i64, _>("n")? as u64,
            submissions_by_state,
            episodes_by_state,
            outcomes,
            failures_by_reason,
            finished_last_minute,
            workers_live: w.try_get::<i64, _>("n")? as u64,
            slots_live: w.try_get::<i64, _>("slots")? as u64,
        })
    }
}
