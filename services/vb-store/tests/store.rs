//! The store's scheduling and result rules, run against SQLite always and against PostgreSQL when
//! `VB_TEST_POSTGRES_URL` names a server (`.ci/run` starts one); the same queries serve both.

use contracts::TaskId;
use sqlx::Row;
use vb_store::*;

mod common;

use common::*;

#[tokio::test]
async fn tokens_are_stored_hashed_and_can_be_revoked() -> anyhow::Result<()> {
    for url in backends("tokens").await? {
        let store = Store::open(&url).await?;
        let token = store.create_token("alice", TokenRole::User, 1.0).await?;
        assert!(token.starts_with("vbt_") && token.len() > 40, "{token}");
        let t = store.check_token(&token).await?.expect("a valid token");
        assert_eq!(
            (t.name.as_str(), t.role),
            ("alice", TokenRole::User),
            "{url}"
        );
        let w = store.create_token("w", TokenRole::Worker, 1.0).await?;
        assert_eq!(
            store.check_token(&w).await?.map(|t| t.role),
            Some(TokenRole::Worker)
        );
        assert_eq!(store.check_token("vbt_wrong").await?, None);
        // Only the hash is in the database.
        let pool = sqlx::AnyPool::connect(&url).await?;
        let rows = sqlx::query("SELECT hash FROM tokens")
            .fetch_all(&pool)
            .await?;
        let hashes: Vec<String> = rows.iter().map(|r| r.get("hash")).collect();
        assert!(hashes.contains(&hash_token(&token)) && hashes.len() == 2);
        assert!(!hashes[0].contains(&token[4..]));
        assert_eq!(store.revoke_tokens("alice").await?, 1);
        assert_eq!(
            store.check_token(&token).await?,
            None,
            "{url}: revoked token still accepted"
        );
    }
    Ok(())
}

#[tokio::test]
async fn leases_results_and_late_duplicates() -> anyhow::Result<()> {
    for url in backends("leases").await? {
        let store = Store::open(&url).await?;
        let r = store.reader();
        let a = store
            .create_submission(&new_submission("a"), &episodes(3), 10.0)
            .await?;
        let b = store
            .create_submission(&new_submission("b"), &episodes(2), 11.0)
            .await?;
        let w1 = store
            .register_worker("w1", 2, "sim-core test", "tk-w", 12.0)
            .await?;
        let w2 = store
            .register_worker("w2", 2, "sim-core test", "tk-w", 12.0)
            .await?;
        // Oldest submission first, in task order.
        let l1 = store.lease(&w1, 2, 30.0, true, 20.0).await?;
        assert_eq!(
            l1.iter().map(|l| l.task_id.to_string()).collect::<Vec<_>>(),
            ["w001-t0", "w001-t1"]
        );
        assert!(l1.iter().all(|l| l.submission.id == a && l.attempt == 1));
        assert_eq!(r.submission(&a).await?.state.as_str(), "running");
        let p = r.progress(&a).await?;
        assert_eq!(
            (p.total, p.running, p.queued, p.finished),
            (3, 2, 1, 0),
            "{url}"
        );
        let pb = r.progress(&b).await?;
        assert_eq!((pb.queue_position, pb.episodes_ahead), (1, 3 + 2), "{url}");
        // First result accepted, the same again is a duplicate.
        assert_eq!(
            store
                .report(&l1[0].worker_id, &result(&l1[0], "success"), 21.0)
                .await?,
            ReportOutcome::Accepted
        );
        assert_eq!(
            store
                .report(&l1[0].worker_id, &result(&l1[0], "rollover"), 22.0)
                .await?,
            ReportOutcome::Duplicate
        );
        let eps = r.episodes(&a).await?;
        assert_eq!(
            eps[0].outcome.map(|o| o.as_str()),
            Some("success"),
            "the duplicate must not overwrite"
        );
        // Worker 1 dies holding w001-t1: after the lease expires it goes to worker 2.
        assert_eq!(store.expire_leases(40.0).await?, 0, "not expired yet");
        assert_eq!(store.expire_leases(51.0).await?, 1);
        let l2 = store.lease(&w2, 1, 30.0, true, 52.0).await?;
        assert_eq!(
            (l2[0].task_id.to_string().as_str(), l2[0].attempt),
            ("w001-t1", 2)
        );
        // Worker 1 was only slow: its late report comes under a lease it no longer holds and is rejected;
        // worker 2 holds the episode now (its lease renews) and its report counts.
        assert_eq!(
            store
                .report(&l1[1].worker_id, &result(&l1[1], "stuck"), 53.0)
                .await?,
            ReportOutcome::Rejected
        );
        assert!(store
            .renew(&w2, &[l2[0].lease_id.clone()], 30.0, 54.0)
            .await?
            .is_empty());
        // A report for worker 2's episode sent as worker 1 is rejected too.
        assert_eq!(
            store.report(&w1, &result(&l2[0], "success"), 54.5).await?,
            ReportOutcome::Rejected
        );
        assert_eq!(
            store
                .report(&l2[0].worker_id, &result(&l2[0], "stuck"), 55.0)
                .await?,
            ReportOutcome::Accepted
        );
        // Exactly one result per task.
        let eps = r.episodes(&a).await?;
        assert_eq!(eps.iter().filter(|e| e.state.as_str() == "done").count(), 2);
        assert_eq!(eps[1].outcome.map(|o| o.as_str()), Some("stuck"));
        let d = r.episode_detail(&a, TaskId::new(1, 1)).await?;
        assert_eq!(
            (d.planner_log.as_str(), d.trajectory_csv.as_str()),
            ("hello", "time,x\n0,0\n")
        );
        // Finishing the last episode finishes the submission.
        let l3 = store.lease(&w2, 1, 30.0, true, 56.0).await?;
        assert_eq!(l3[0].task_id, contracts::TaskId::new(1, 2));
        store
            .report(&l3[0].worker_id, &result(&l3[0], "success"), 57.0)
            .await?;
        let s = r.submission(&a).await?;
        assert_eq!(
            (s.state.as_str(), s.finished_at),
            ("done", Some(57.0)),
            "{url}"
        );
        let p = r.progress(&a).await?;
        assert_eq!((p.finished, p.successes, p.queue_position), (3, 2, 0));
        assert!(matches!(
            r.submission("sub-nope").await,
            Err(StoreError::UnknownSubmission(_))
        ));
        assert!(matches!(
            r.episode_detail(&a, TaskId::new(9, 9)).await,
            Err(StoreError::UnknownEpisode { .. })
        ));
    }
    Ok(())
}

#[tokio::test]
async fn lost_episodes_are_retried_then_recorded_as_infrastructure_failures() -> anyhow::Result<()>
{
    for url in backends("retries").await? {
        let store = Store::open(&url).await?;
        let id = store
            .create_submission(&new_submission("a"), &episodes(1), 0.0)
            .await?;
        // Workers of four different tokens each die holding it.
        let mut t = 1.0;
        let mut w = String::new();
        for attempt in 1..=MAX_ATTEMPTS {
            w = store
                .register_worker("w", 1, "sim-core test", &format!("tk-{attempt}"), t)
                .await?;
            let l = store.lease(&w, 1, 5.0, true, t).await?;
            assert_eq!(l.len(), 1, "{url}: attempt {attempt} got no lease");
            assert_eq!(l[0].attempt, attempt);
            t += 10.0;
            store.expire_leases(t).await?;
        }
        assert!(store.lease(&w, 1, 5.0, true, t).await?.is_empty());
        let e = &store.reader().episodes(&id).await?[0];
        assert_eq!(
            (e.state.as_str(), e.outcome.map(|o| o.as_str()), e.reason),
            (
                "done",
                Some("error"),
                Some(contracts::EndReason::Infrastructure)
            )
        );
        assert!(
            e.detail
                .as_deref()
                .unwrap_or("")
                .contains(&MAX_ATTEMPTS.to_string()),
            "{:?}",
            e.detail
        );
        assert_eq!(store.reader().submission(&id).await?.state.as_str(), "done");
        // A worker that could not run an episode (e.g. missing task set) releases it at once.
        let id2 = store
            .create_submission(&new_submission("b"), &episodes(1), t)
            .await?;
        let l = store.lease(&w, 1, 60.0, true, t).await?;
        store
            .release(&w, &l[0].lease_id, "no such image", t + 1.0)
            .await?;
        let again = store.lease(&w, 1, 60.0, true, t + 2.0).await?;
        assert_eq!(
            (again[0].submission.id.as_str(), again[0].attempt),
            (id2.as_str(), 2)
        );
        // Workers that cannot run it, again and again: the recorded failure says why.
        let mut t = t + 3.0;
        store
            .release(&w, &again[0].lease_id, "no such image", t)
            .await?;
        for k in 0..MAX_ATTEMPTS {
            let w = store
                .register_worker("w", 1, "sim-core test", &format!("tk-img-{k}"), t)
                .await?;
            if let Some(l) = store.lease(&w, 1, 60.0, true, t).await?.pop() {
                store
                    .release(&w, &l.lease_id, "docker image inspect x failed", t + 0.5)
                    .await?;
            }
            t += 1.0;
        }
        let e = &store.reader().episodes(&id2).await?[0];
        assert_eq!(
            e.reason,
            Some(contracts::EndReason::Infrastructure),
            "{url}"
        );
        let detail = e.detail.as_deref().unwrap_or("");
        assert!(
            detail.contains("lost by a worker")
                && detail.contains("last error: docker image inspect x failed"),
            "{url}: {detail}"
        );
    }
    Ok(())
}

#[tokio::test]
async fn one_token_leasing_and_dropping_cannot_use_up_an_episode() -> anyhow::Result<()> {
    for url in backends("drops").await? {
        let store = Store::open(&url).await?;
        let id = store
            .create_submission(&new_submission("a"), &episodes(1), 0.0)
            .await?;
        let mut t = 1.0;
        for round in 0..3 * MAX_ATTEMPTS {
            // A new worker id each time, under the same token.
            let w = store
                .register_worker("rogue", 1, "sim-core test", "tk-rogue", t)
                .await?;
            let l = store.lease(&w, 1, 5.0, true, t).await?;
            assert_eq!(l.len(), 1, "{url}: round {round}");
            assert!(
                l[0].attempt <= 2,
                "{url}: round {round}: attempt {}",
                l[0].attempt
            );
            t += 10.0;
            store.expire_leases(t).await?;
        }
        let e = &store.reader().episodes(&id).await?[0];
        assert_eq!(
            e.state.as_str(),
            "queued",
            "{url}: the episode is still there to run"
        );
        assert_eq!(
            store.drops_since("tk-rogue", 0.0).await?,
            3 * MAX_ATTEMPTS as u64
        );
        // Drops at t - 20, t - 10 and t are in the last 25 s.
        assert_eq!(
            store.drops_since("tk-rogue", t - 25.0).await?,
            3,
            "only the window counts"
        );
        assert_eq!(store.drops_since("tk-other", 0.0).await?, 0);
        // An honest worker of another token then runs it.
        let w = store
            .register_worker("honest", 1, "sim-core test", "tk-honest", t)
            .await?;
        let l = store.lease(&w, 1, 5.0, true, t).await?;
        assert_eq!(
            store.report(&w, &result(&l[0], "success"), t + 1.0).await?,
            ReportOutcome::Accepted
        );
    }
    Ok(())
}

#[tokio::test]
async fn cancel_keeps_finished_episodes_and_marks_the_rest_not_run() -> anyhow::Result<()> {
    for url in backends("cancel").await? {
        let store = Store::open(&url).await?;
        let id = store
            .create_submission(&new_submission("a"), &episodes(4), 0.0)
            .await?;
        let w = store
            .register_worker("w", 2, "sim-core test", "tk-w", 0.0)
            .await?;
        let l = store.lease(&w, 2, 30.0, true, 1.0).await?;
        store
            .report(&l[0].worker_id, &result(&l[0], "success"), 2.0)
            .await?;
        assert!(store.cancel(&id, 3.0).await?);
        assert!(!store.cancel(&id, 3.5).await?, "cancelling twice");
        // The running episode's lease is no longer renewed; a result that arrives anyway is kept (it did run).
        assert_eq!(
            store
                .renew(&w, &[l[1].lease_id.clone()], 30.0, 4.0)
                .await?
                .len(),
            1
        );
        assert!(
            store.lease(&w, 2, 30.0, true, 4.0).await?.is_empty(),
            "cancelled work must not be leased"
        );
        let p = store.reader().progress(&id).await?;
        assert_eq!(
            (p.finished, p.running, p.not_run, p.queued),
            (1, 1, 2, 0),
            "{url}"
        );
        store.expire_leases(100.0).await?;
        let p = store.reader().progress(&id).await?;
        assert_eq!((p.finished, p.running, p.not_run), (1, 0, 3), "{url}");
        let s = store.reader().submission(&id).await?;
        assert_eq!(s.state.as_str(), "cancelled");
        assert_eq!(
            store
                .report(&l[1].worker_id, &result(&l[1], "success"), 101.0)
                .await?,
            ReportOutcome::Rejected
        );
    }
    Ok(())
}

#[tokio::test]
async fn reopening_keeps_everything() -> anyhow::Result<()> {
    for url in backends("reopen").await? {
        let id = {
            let store = Store::open(&url).await?;
            let id = store
                .create_submission(&new_submission("a"), &episodes(2), 0.0)
                .await?;
            let w = store
                .register_worker("w", 1, "sim-core test", "tk-w", 0.0)
                .await?;
            let l = store.lease(&w, 1, 30.0, true, 1.0).await?;
            store
                .report(&l[0].worker_id, &result(&l[0], "success"), 2.0)
                .await?;
            id
        };
        // A restarted coordinator opens (and re-runs the migrations on) the same database.
        let store = Store::open(&url).await?;
        let p = store.reader().progress(&id).await?;
        assert_eq!((p.total, p.finished, p.queued), (2, 1, 1), "{url}");
        let reader = Reader::open(&url).await?;
        assert_eq!(reader.submissions().await?.len(), 1);
    }
    Ok(())
}

#[tokio::test]
async fn bad_urls_are_refused_with_a_clear_error() {
    let e = Store::open("mysql://nope").await.unwrap_err();
    assert!(e.to_string().contains("unsupported database URL"), "{e}");
    let e = Store::open("sqlite:///nonexistent-dir/deeper/vb.db")
        .await
        .unwrap_err();
    assert!(e.to_string().contains("database"), "{e}");
}
