//! Hand-backs: a stopping worker's unrun episodes go back to the queue without using an attempt, and every hand-back
//! is recorded against the worker's token, so the coordinator can limit a token's rate of them.

use vb_store::*;

#[allow(dead_code)]
mod common;

use common::*;

#[tokio::test]
async fn hand_backs_use_no_attempt_and_are_counted_per_token_in_a_window() -> anyhow::Result<()> {
    for url in backends("hand-backs").await? {
        let store = Store::open(&url).await?;
        let sub = store
            .create_submission(&new_submission("a"), &episodes(2), 1.0)
            .await?;
        let w = store
            .register_worker("looper", 2, "sim-core test", "tk-loop", 1.0)
            .await?;
        // Lease and hand back the same episodes again and again, one second apart.
        let rounds = 3 * MAX_ATTEMPTS as u32;
        for i in 0..rounds {
            let t = 10.0 + f64::from(i);
            let leases = store.lease(&w, 2, 30.0, false, t).await?;
            assert_eq!(leases.len(), 2, "{url}: round {i}");
            assert!(
                leases.iter().all(|l| l.attempt == 1),
                "{url}: a hand-back used an attempt"
            );
            for l in &leases {
                assert!(store.hand_back(&w, &l.lease_id, t).await?, "{url}");
            }
        }
        let last = 10.0 + f64::from(rounds - 1);
        assert_eq!(
            store.hand_backs_since("tk-loop", 0.0).await?,
            2 * u64::from(rounds),
            "{url}"
        );
        assert_eq!(
            store.hand_backs_since("tk-loop", last - 2.5).await?,
            6,
            "{url}: only the window counts"
        );
        assert_eq!(store.hand_backs_since("tk-other", 0.0).await?, 0);
        // Hand-backs are not drops: the drop budget is untouched.
        assert_eq!(store.drops_since("tk-loop", 0.0).await?, 0, "{url}");
        // A lease that is no longer the worker's is not handed back, and not counted.
        let leases = store.lease(&w, 1, 30.0, false, last + 1.0).await?;
        assert!(store.hand_back(&w, &leases[0].lease_id, last + 1.0).await?);
        assert!(!store.hand_back(&w, &leases[0].lease_id, last + 1.0).await?);
        assert_eq!(
            store.hand_backs_since("tk-loop", 0.0).await?,
            2 * u64::from(rounds) + 1,
            "{url}"
        );
        let p = store.reader().progress(&sub).await?;
        assert_eq!((p.queued, p.finished), (2, 0), "{url}");
        // A refusal (a worker that cannot run the submission) gives the lease back unrun too, and is counted alike.
        let leases = store.lease(&w, 1, 30.0, false, last + 2.0).await?;
        assert!(
            store
                .refuse(&w, &leases[0].lease_id, "no image", last + 2.0)
                .await?
        );
        assert_eq!(
            store.hand_backs_since("tk-loop", 0.0).await?,
            2 * u64::from(rounds) + 2,
            "{url}"
        );
        let p = store.reader().progress(&sub).await?;
        assert_eq!((p.queued, p.finished), (2, 0), "{url}");
    }
    Ok(())
}
