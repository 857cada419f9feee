//! Trajectories and planner logs, gzip-compressed in their own table (`episode_blobs`), out of the episodes table
//! that scheduling and the leaderboard scan.

use crate::{Result, StoreError};
use flate2::read::GzDecoder;
use flate2::write::GzEncoder;
use sqlx::{Any, AnyPool, Row, Transaction};
use std::io::{Read, Write};

/// Episodes moved per transaction when an older store's inline trajectories are moved out.
const MOVE_BATCH: i64 = 200;

pub(crate) fn gzip(text: &str) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), flate2::Compression::fast());
    // Writing into a Vec cannot fail.
    let _ = e.write_all(text.as_bytes());
    e.finish().unwrap_or_default()
}

pub(crate) fn gunzip(bytes: &[u8]) -> Result<String> {
    let mut s = String::new();
    GzDecoder::new(bytes)
        .read_to_string(&mut s)
        .map_err(|e| StoreError::Corrupt(format!("compressed trajectory or log: {e}")))?;
    Ok(s)
}

/// An episode's trajectory and log, compressed.
pub(crate) struct Compressed {
    trajectory: Vec<u8>,
    log: Vec<u8>,
}

impl Compressed {
    pub(crate) fn new(trajectory_csv: &str, planner_log: &str) -> Compressed {
        Compressed {
            trajectory: gzip(trajectory_csv),
            log: gzip(planner_log),
        }
    }

    /// A reported result's: its trajectory as the worker compressed it, if it did.
    pub(crate) fn of(r: &crate::EpisodeResultIn) -> Compressed {
        match &r.trajectory_gz {
            Some(gz) => Compressed {
                trajectory: gz.clone(),
                log: gzip(&r.planner_log),
            },
            None => Compressed::new(&r.trajectory_csv, &r.planner_log),
        }
    }
}

/// Stores an episode's trajectory and log (an episode that already has them keeps the first).
pub(crate) async fn insert(
    tx: &mut Transaction<'static, Any>,
    submission_id: &str,
    task: contracts::TaskId,
    blobs: &Compressed,
) -> Result<()> {
    sqlx::query(
        "INSERT INTO episode_blobs (submission_id, task_id, trajectory_gz, planner_log_gz) VALUES ($1, $2, $3, $4) \
         ON CONFLICT (submission_id, task_id) DO NOTHING",
    )
    .bind(submission_id)
    .bind(task.to_string())
    .bind(&blobs.trajectory)
    .bind(&blobs.log)
    .execute(&mut **tx)
    .await?;
    Ok(())
}

/// An episode's trajectory CSV and planner log ("" when it has none). Reads the old inline columns for a store the
/// coordinator has not opened (and so not moved) since it was upgraded.
pub(crate) async fn read(
    pool: &AnyPool,
    submission_id: &str,
    task: contracts::TaskId,
) -> Result<(String, String)> {
    let task_id = task.to_string();
    let row = sqlx::query(
        "SELECT trajectory_gz, planner_log_gz FROM episode_blobs WHERE submission_id = $1 AND task_id = $2",
    )
    .bind(submission_id)
    .bind(&task_id)
    .fetch_optional(pool)
    .await?;
    if let Some(r) = row {
        let text = |c: &str| -> Result<String> {
            match r.try_get::<Option<Vec<u8>>, _>(c)? {
                Some(b) => gunzip(&b),
                None => Ok(String::new()),
            }
        };
        return Ok((text("trajectory_gz")?, text("planner_log_gz")?));
    }
    let r = sqlx::query(
        "SELECT trajectory_csv, planner_log FROM episodes WHERE submission_id = $1 AND task_id = $2",
    )
    .bind(submission_id)
    .bind(&task_id)
    .fetch_optional(pool)
    .await?;
    Ok(match r {
        Some(r) => (
            r.try_get::<Option<String>, _>("trajectory_csv")?
                .unwrap_or_default(),
            r.try_get::<Option<String>, _>("planner_log")?
                .unwrap_or_default(),
        ),
        None => (String::new(), String::new()),
    })
}

/// Moves trajectories and logs stored inline by an older version into `episode_blobs`, a batch per transaction,
/// and empties the inline columns. Returns how many episodes moved.
pub(crate) async fn move_inline(pool: &AnyPool) -> Result<u64> {
    let mut moved = 0;
    loop {
        let mut tx = pool.begin().await?;
        let rows = sqlx::query(
            "SELECT submission_id, task_id, trajectory_csv, planner_log FROM episodes \
             WHERE trajectory_csv IS NOT NULL OR planner_log IS NOT NULL LIMIT $1",
        )
        .bind(MOVE_BATCH)
        .fetch_all(&mut *tx)
        .await?;
        if rows.is_empty() {
            return Ok(moved);
        }
        for r in &rows {
            let sub: String = r.try_get("submission_id")?;
            let task: String = r.try_get("task_id")?;
            let id: contracts::TaskId = task
                .parse()
                .map_err(|e: contracts::TaskIdError| StoreError::Corrupt(e.to_string()))?;
            let traj: Option<String> = r.try_get("trajectory_csv")?;
            let log: Option<String> = r.try_get("planner_log")?;
            let blobs =
                Compressed::new(traj.as_deref().unwrap_or(""), log.as_deref().unwrap_or(""));
            insert(&mut tx, &sub, id, &blobs).await?;
            sqlx::query(
                "UPDATE episodes SET trajectory_csv = NULL, planner_log = NULL WHERE submission_id = $1 AND task_id = $2",
            )
            .bind(&sub)
            .bind(&task)
            .execute(&mut *tx)
            .await?;
            moved += 1;
        }
        tx.commit().await?;
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn gzip_round_trips() {
        for text in ["", "time,x\n0,1\n", &"é,".repeat(10_000)] {
            assert_eq!(super::gunzip(&super::gzip(text)).unwrap(), text);
        }
        assert!(super::gunzip(b"not gzip").is_err());
    }
}
