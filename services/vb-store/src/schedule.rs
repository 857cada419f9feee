//! Submissions and their scheduling: creation, cancelling, leases (expiry, renewal, release) and drops.

use crate::*;
use sqlx::Row;

impl Store {
    /// Stores a submission and one queued episode per task, atomically.
    pub async fn create_submission(
        &self,
        s: &NewSubmission,
        episodes: &[NewEpisode],
        now: f64,
    ) -> Result<String> {
        let mut ids = self
            .create_family(std::slice::from_ref(s), episodes, now)
            .await?;
        Ok(ids.remove(0))
    }

    /// Stores the submissions of one request (one per perception profile, at least one), each with one queued
    /// episode per task, atomically and in order; the first one's id is the family of all. Returns their ids.
    pub async fn create_family(
        &self,
        subs: &[NewSubmission],
        episodes: &[NewEpisode],
        now: f64,
    ) -> Result<Vec<String>> {
        let _w = self.write.lock().await;
        let mut tx = self.pool.begin().await?;
        let mut ids: Vec<String> = Vec::with_capacity(subs.len());
        for s in subs {
            let id = format!("sub-{}", random_hex(6)?);
            let family = ids.first().unwrap_or(&id).clone();
            insert_submission(&mut tx, s, &id, &family, episodes, now).await?;
            ids.push(id);
        }
        tx.commit().await?;
        Ok(ids)
    }
}

/// One submission (of family `family`) and its queued episodes, in `tx`.
async fn insert_submission(
    tx: &mut sqlx::Transaction<'_, sqlx::Any>,
    s: &NewSubmission,
    id: &str,
    family: &str,
    episodes: &[NewEpisode],
    now: f64,
) -> Result<()> {
    let seq: i64 =
        sqlx::query("SELECT CAST(COALESCE(MAX(seq), 0) + 1 AS BIGINT) AS next FROM submissions")
            .fetch_one(&mut **tx)
            .await?
            .try_get("next")?;
    sqlx::query(
        "INSERT INTO submissions (id, seq, name, owner, planner_kind, planner_spec, planner_identity, vehicle, \
         scale, seed, step_deadline_s, task_set_version, sim_version, state, created_at, owner_token, tasks, \
         perception, perception_params, family) \
         VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13, 'queued', $14, $15, $16, $17, $18, $19)",
    )
    .bind(id)
        .bind(seq)
        .bind(&s.name)
        .bind(&s.owner)
        .bind(s.planner.kind().as_str())
        .bind(s.planner.column())
        .bind(&s.planner_identity)
        .bind(s.vehicle.as_str())
        .bind(s.scale)
        .bind(s.seed as i64)
        .bind(s.step_deadline_s)
        .bind(&s.task_set_version)
        .bind(s.sim_version.as_str())
        .bind(now)
        .bind(&s.owner_token)
        .bind(episodes.len() as i64)
        .bind(s.perception.id.as_str())
        .bind(&s.perception.params)
        .bind(family)
        .execute(&mut **tx)
        .await?;
    for (i, e) in episodes.iter().enumerate() {
        sqlx::query(
            "INSERT INTO episodes (submission_id, task_id, ord, world_id, task_index, level, semantics, density, \
             state, attempts) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, 'queued', 0)",
        )
        .bind(id)
        .bind(e.task_id.to_string())
        .bind(i as i64)
        .bind(i64::from(e.task_id.world))
        .bind(i64::from(e.task_id.index))
        .bind(e.level.as_str())
        .bind(e.semantics.as_str())
        .bind(e.density.as_str())
        .execute(&mut **tx)
        .await?;
    }
    Ok(())
}

impl Store {
    /// Cancels a submission: queued episodes become `not_run`; leased ones may still report (their results are
    /// kept), and become `not_run` when their lease expires. Returns false when it had already ended.
    pub async fn cancel(&self, id: &str, now: f64) -> Result<bool> {
        let _w = self.write.lock().await;
        let sub = self.reader().submission(id).await?;
        if !sub.state.is_active() {
            return Ok(false);
        }
        let mut tx = self.pool.begin().await?;
        sqlx::query("UPDATE submissions SET state = 'cancelled', finished_at = $1 WHERE id = $2")
            .bind(now)
            .bind(id)
            .execute(&mut *tx)
            .await?;
        sqlx::query(
            "UPDATE episodes SET state = 'not_run' WHERE submission_id = $1 AND state = 'queued'",
        )
        .bind(id)
        .execute(&mut *tx)
        .await?;
        tx.commit().await?;
        Ok(true)
    }

    /// Returns expired leases to the queue (or marks them `not_run` for cancelled submissions, or records an
    /// infrastructure failure after [`MAX_ATTEMPTS`]). Returns how many leases expired.
    pub async fn expire_leases(&self, now: f64) -> Result<u64> {
        let _w = self.write.lock().await;
        self.expire_leases_locked(now).await
    }

    async fn expire_leases_locked(&self, now: f64) -> Result<u64> {
        let mut tx = self.pool.begin().await?;
        // A token that already dropped this episode does not use up another of its attempts ...
        sqlx::query(
            "UPDATE episodes SET attempts = attempts - 1 WHERE state = 'leased' AND lease_expires < $1 \
             AND EXISTS (SELECT 1 FROM lease_drops d JOIN workers w ON w.token_id = d.token_id \
             WHERE w.id = episodes.worker_id AND d.submission_id = episodes.submission_id \
             AND d.task_id = episodes.task_id)",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        // ... and every drop is recorded against the token of the worker that held the lease.
        sqlx::query(
            "INSERT INTO lease_drops (token_id, worker_id, submission_id, task_id, at) \
             SELECT w.token_id, e.worker_id, e.submission_id, e.task_id, $1 FROM episodes e \
             JOIN workers w ON w.id = e.worker_id WHERE e.state = 'leased' AND e.lease_expires < $1",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?;
        let a = sqlx::query(
            "UPDATE episodes SET state = 'not_run', lease_id = NULL, worker_id = NULL, lease_expires = NULL \
             WHERE state = 'leased' AND lease_expires < $1 \
             AND submission_id IN (SELECT id FROM submissions WHERE state = 'cancelled')",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        let b = sqlx::query(
            "UPDATE episodes SET state = 'done', outcome = 'error', reason = 'infrastructure', \
             detail = 'the episode was lost by a worker ' || CAST(attempts AS TEXT) || ' times (worker died or \
             could not run it)' || CASE WHEN detail IS NULL THEN '' ELSE '; last error: ' || detail END, \
             lease_id = NULL, lease_expires = NULL, finished_at = $1 \
             WHERE state = 'leased' AND lease_expires < $1 AND attempts >= $2",
        )
        .bind(now)
        .bind(MAX_ATTEMPTS)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        let c = sqlx::query(
            "UPDATE episodes SET state = 'queued', lease_id = NULL, worker_id = NULL, lease_expires = NULL \
             WHERE state = 'leased' AND lease_expires < $1",
        )
        .bind(now)
        .execute(&mut *tx)
        .await?
        .rows_affected();
        tx.commit().await?;
        if a + b + c > 0 {
            self.finish_submissions(now).await?;
        }
        Ok(a + b + c)
    }

    /// Leases up to `max` queued episodes to `worker_id` for `lease_s` seconds, oldest submission first (exec and
    /// image planners only to a worker that `runs_exec`). The caller serialises calls (the coordinator holds a lock),
    /// so two workers never lease the same row.
    pub async fn lease(
        &self,
        worker_id: &str,
        max: u32,
        lease_s: f64,
        runs_exec: bool,
        now: f64,
    ) -> Result<Vec<Lease>> {
        let kinds = PlannerKinds {
            exec: runs_exec,
            image: runs_exec,
        };
        self.lease_kinds(worker_id, max, lease_s, kinds, now).await
    }

    /// [`Store::lease`] for a worker that runs the planner `kinds` it names: episodes of the other kinds stay
    /// queued for a worker that runs them (an image submission waits for a worker with Docker).
    pub async fn lease_kinds(
        &self,
        worker_id: &str,
        max: u32,
        lease_s: f64,
        kinds: PlannerKinds,
        now: f64,
    ) -> Result<Vec<Lease>> {
        let _w = self.write.lock().await;
        if max == 0 {
            return Ok(Vec::new());
        }
        let rows = sqlx::query(
            "SELECT e.submission_id, e.task_id, e.attempts FROM episodes e JOIN submissions s ON s.id = e.submission_id \
             WHERE e.state = 'queued' AND s.state IN ('queued', 'running') \
             AND ($2 = 1 OR s.planner_kind <> 'exec') AND ($3 = 1 OR s.planner_kind <> 'image') \
             AND NOT EXISTS (SELECT 1 FROM worker_refusals r WHERE r.worker_id = $4 AND r.submission_id = s.id) \
             ORDER BY s.seq, e.ord LIMIT $1",
        )
        .bind(max as i64)
        .bind(i64::from(kinds.exec))
        .bind(i64::from(kinds.image))
        .bind(worker_id)
        .fetch_all(&self.pool)
        .await?;
        let mut out = Vec::with_capacity(rows.len());
        let mut tx = self.pool.begin().await?;
        for r in &rows {
            let submission_id: String = r.try_get("submission_id")?;
            let task_id: String = r.try_get("task_id")?;
            let task: contracts::TaskId = task_id
                .parse()
                .map_err(|e| StoreError::Corrupt(format!("episode of {submission_id}: {e}")))?;
            let attempts: i64 = r.try_get("attempts")?;
            let lease_id = format!("ls-{}", random_hex(8)?);
            let n = sqlx::query(
                "UPDATE episodes SET state = 'leased', lease_id = $1, worker_id = $2, lease_expires = $3, \
                 attempts = attempts + 1 WHERE submission_id = $4 AND task_id = $5 AND state = 'queued'",
            )
            .bind(&lease_id)
            .bind(worker_id)
            .bind(now + lease_s)
            .bind(&submission_id)
            .bind(&task_id)
            .execute(&mut *tx)
            .await?
            .rows_affected();
            if n == 1 {
                sqlx::query(
                    "UPDATE submissions SET state = 'running' WHERE id = $1 AND state = 'queued'",
                )
                .bind(&submission_id)
                .execute(&mut *tx)
                .await?;
                out.push((lease_id, submission_id, task, attempts + 1));
            }
        }
        tx.commit().await?;
        let reader = self.reader();
        let mut leases = Vec::with_capacity(out.len());
        for (lease_id, sid, task_id, attempt) in out {
            leases.push(Lease {
                lease_id,
                worker_id: worker_id.to_string(),
                submission: reader.submission(&sid).await?,
                task_id,
                attempt,
            });
        }
        Ok(leases)
    }

    /// Extends the leases `lease_ids` held by `worker_id`; returns those that are no longer this worker's to run
    /// (expired and handed to someone else, finished, or cancelled), which the worker must abandon.
    pub async fn renew(
        &self,
        worker_id: &str,
        lease_ids: &[String],
        lease_s: f64,
        now: f64,
    ) -> Result<Vec<String>> {
        let _w = self.write.lock().await;
        let mut gone = Vec::new();
        for id in lease_ids {
            let n = sqlx::query(
                "UPDATE episodes SET lease_expires = $1 WHERE lease_id = $2 AND worker_id = $3 AND state = 'leased' \
                 AND submission_id IN (SELECT id FROM submissions WHERE state <> 'cancelled')",
            )
            .bind(now + lease_s)
            .bind(id)
            .bind(worker_id)
            .execute(&self.pool)
            .await?
            .rows_affected();
            if n == 0 {
                gone.push(id.clone());
            }
        }
        Ok(gone)
    }

    /// How many leases the workers of token `token_id` dropped since `since`.
    pub async fn drops_since(&self, token_id: &str, since: f64) -> Result<u64> {
        self.count_since(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM lease_drops WHERE token_id = $1 AND at > $2",
            token_id,
            since,
        )
        .await
    }

    /// How many leases the workers of token `token_id` gave back unrun since `since` ([`Store::hand_back`] and
    /// [`Store::refuse`]).
    pub async fn hand_backs_since(&self, token_id: &str, since: f64) -> Result<u64> {
        self.count_since(
            "SELECT CAST(COUNT(*) AS BIGINT) AS n FROM lease_hand_backs WHERE token_id = $1 AND at > $2",
            token_id,
            since,
        )
        .await
    }

    /// The count `sql` gives for a token id ($1) and a time ($2).
    async fn count_since(&self, sql: &str, token_id: &str, since: f64) -> Result<u64> {
        let n: i64 = sqlx::query(sql)
            .bind(token_id)
            .bind(since)
            .fetch_one(&self.pool)
            .await?
            .try_get("n")?;
        Ok(n as u64)
    }

    /// Worker `worker_id` could not run its leased episode (not the planner's fault; `why`, kept for the record if
    /// the episode finally fails this way): it goes back to the queue.
    pub async fn release(
        &self,
        worker_id: &str,
        lease_id: &str,
        why: &str,
        now: f64,
    ) -> Result<()> {
        let _w = self.write.lock().await;
        sqlx::query(
            "UPDATE episodes SET lease_expires = $1, detail = $4 WHERE lease_id = $2 AND worker_id = $3 \
             AND state = 'leased'",
        )
        .bind(now - 1.0)
        .bind(lease_id)
        .bind(worker_id)
        .bind(why)
        .execute(&self.pool)
        .await?;
        self.expire_leases_locked(now).await?;
        Ok(())
    }

    /// Worker `worker_id` is stopping and hands back its leased episode unfinished: it goes back to the queue (a
    /// cancelled submission's is marked not run) at once, without using up an attempt or counting as a dropped
    /// lease; the hand-back is recorded against the worker's token (`lease_hand_backs`), whose rate the coordinator
    /// limits ([`Store::hand_backs_since`]). Whether the lease was still the worker's.
    pub async fn hand_back(&self, worker_id: &str, lease_id: &str, now: f64) -> Result<bool> {
        let _w = self.write.lock().await;
        let mut tx = self.pool.begin().await?;
        record_hand_back(&mut tx, worker_id, lease_id, now).await?;
        let n = requeue_unused(&mut tx, worker_id, lease_id, None).await?;
        tx.commit().await?;
        if n > 0 {
            self.finish_submissions(now).await?;
        }
        Ok(n > 0)
    }

    /// Worker `worker_id` cannot run its leased episode's submission at all (`why`: e.g. it lacks the image): the
    /// episode goes back to the queue without using an attempt, with `why` as its detail, and no episode of that
    /// submission is leased to this worker again, so they wait for a worker that can run them. Counted with the
    /// token's hand-backs. Whether the lease was still the worker's.
    pub async fn refuse(
        &self,
        worker_id: &str,
        lease_id: &str,
        why: &str,
        now: f64,
    ) -> Result<bool> {
        let _w = self.write.lock().await;
        let mut tx = self.pool.begin().await?;
        let row = sqlx::query(
            "SELECT submission_id FROM episodes WHERE lease_id = $1 AND worker_id = $2 AND state = 'leased'",
        )
        .bind(lease_id)
        .bind(worker_id)
        .fetch_optional(&mut *tx)
        .await?;
        let Some(row) = row else {
            return Ok(false);
        };
        let submission_id: String = row.try_get("submission_id")?;
        // Given back unrun like a hand-back, and counted with them: otherwise a token could lease and refuse in a
        // loop (a new worker id each time) instead.
        record_hand_back(&mut tx, worker_id, lease_id, now).await?;
        sqlx::query(
            "INSERT INTO worker_refusals (worker_id, submission_id, reason, at) VALUES ($1, $2, $3, $4) \
             ON CONFLICT (worker_id, submission_id) DO NOTHING",
        )
        .bind(worker_id)
        .bind(&submission_id)
        .bind(why)
        .bind(now)
        .execute(&mut *tx)
        .await?;
        let why = format!("waiting for a worker that can run it: {why}");
        requeue_unused(&mut tx, worker_id, lease_id, Some(&why)).await?;
        tx.commit().await?;
        self.finish_submissions(now).await?;
        Ok(true)
    }
}

/// Records worker `worker_id`'s leased episode `lease_id`, about to be given back unrun, against its token.
async fn record_hand_back(
    tx: &mut sqlx::Transaction<'static, sqlx::Any>,
    worker_id: &str,
    lease_id: &str,
    now: f64,
) -> Result<()> {
    sqlx::query(
        "INSERT INTO lease_hand_backs (token_id, worker_id, submission_id, task_id, at) \
         SELECT w.token_id, e.worker_id, e.submission_id, e.task_id, $3 FROM episodes e \
         JOIN workers w ON w.id = e.worker_id WHERE e.lease_id = $1 AND e.worker_id = $2 AND e.state = 'leased'",
    )
    .bind(lease_id)
    .bind(worker_id)
    .bind(now)
    .execute(&mut **tx)
    .await?;
    Ok(())
}

/// Returns worker `worker_id`'s leased episode `lease_id` unused: queued again (not run, if its submission was
/// cancelled meanwhile) with its attempt given back and, when given, `detail` saying why. The episodes changed (0
/// when the lease is no longer the worker's).
async fn requeue_unused(
    tx: &mut sqlx::Transaction<'static, sqlx::Any>,
    worker_id: &str,
    lease_id: &str,
    detail: Option<&str>,
) -> Result<u64> {
    Ok(sqlx::query(
        "UPDATE episodes SET state = CASE WHEN submission_id IN \
         (SELECT id FROM submissions WHERE state = 'cancelled') THEN 'not_run' ELSE 'queued' END, \
         attempts = attempts - 1, detail = COALESCE($3, detail), lease_id = NULL, worker_id = NULL, \
         lease_expires = NULL WHERE lease_id = $1 AND worker_id = $2 AND state = 'leased'",
    )
    .bind(lease_id)
    .bind(worker_id)
    .bind(detail)
    .execute(&mut **tx)
    .await?
    .rows_affected())
}
