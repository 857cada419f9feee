//! Which worker gets which planner: exec and image planners go only to workers that run them, and a submission a
//! worker refused waits for one that can run it. SQLite always, PostgreSQL when `VB_TEST_POSTGRES_URL` names a server.

// Only part of the shared helpers is used here.
#[allow(dead_code)]
mod common;

use common::*;
use vb_store::*;

#[tokio::test]
async fn workers_that_do_not_run_exec_planners_get_none() -> anyhow::Result<()> {
    for url in backends("noexec").await? {
        let store = Store::open(&url).await?;
        let mut exec = new_submission("exec");
        exec.planner = vb_store::PlannerSpec::Exec(vec!["planner".into()]);
        store.create_submission(&exec, &episodes(1), 0.0).await?;
        let builtin = store
            .create_submission(&new_submission("builtin"), &episodes(1), 1.0)
            .await?;
        let w = store
            .register_worker("w", 2, "sim-core test", "tk", 2.0)
            .await?;
        let l = store.lease(&w, 2, 30.0, false, 3.0).await?;
        assert_eq!(l.len(), 1, "{url}");
        assert_eq!(l[0].submission.id, builtin);
        assert_eq!(store.lease(&w, 2, 30.0, true, 4.0).await?.len(), 1, "{url}");
    }
    Ok(())
}

/// An image submission waits for a worker with Docker: a worker that runs exec planners but no images takes the
/// later submissions and leaves the image's episodes queued.
#[tokio::test]
async fn image_planners_wait_for_a_worker_that_runs_them() -> anyhow::Result<()> {
    for url in backends("images").await? {
        let store = Store::open(&url).await?;
        let mut image = new_submission("image");
        image.planner = vb_store::PlannerSpec::Image("planner:latest".into());
        let image = store.create_submission(&image, &episodes(2), 0.0).await?;
        let mut exec = new_submission("exec");
        exec.planner = vb_store::PlannerSpec::Exec(vec!["planner".into()]);
        let exec = store.create_submission(&exec, &episodes(1), 1.0).await?;
        let w = store
            .register_worker("w", 4, "sim-core test", "tk", 2.0)
            .await?;
        let no_docker = PlannerKinds {
            exec: true,
            image: false,
        };
        let l = store.lease_kinds(&w, 4, 30.0, no_docker, 3.0).await?;
        assert_eq!(l.len(), 1, "{url}");
        assert_eq!(l[0].submission.id, exec, "{url}");
        let p = store.reader().progress(&image).await?;
        assert_eq!(
            (p.queued, p.running),
            (2, 0),
            "{url}: the image's episodes still wait"
        );
        let docker = PlannerKinds {
            exec: true,
            image: true,
        };
        let l = store.lease_kinds(&w, 4, 30.0, docker, 4.0).await?;
        assert_eq!(l.len(), 2, "{url}");
        assert!(l.iter().all(|x| x.submission.id == image), "{url}");
    }
    Ok(())
}

/// A worker that cannot run a submission (it lacks the image) refuses it: the episode is queued again without using
/// an attempt, says why it waits, and is never leased to that worker again; another worker gets it.
#[tokio::test]
async fn a_refused_submission_waits_for_a_worker_that_can_run_it() -> anyhow::Result<()> {
    for url in backends("refuse").await? {
        let store = Store::open(&url).await?;
        let mut image = new_submission("image");
        image.planner = vb_store::PlannerSpec::Image("planner:latest".into());
        let id = store.create_submission(&image, &episodes(1), 0.0).await?;
        let docker = PlannerKinds {
            exec: true,
            image: true,
        };
        let a = store
            .register_worker("a", 1, "sim-core test", "tk-a", 1.0)
            .await?;
        let b = store
            .register_worker("b", 1, "sim-core test", "tk-b", 1.0)
            .await?;
        let l = store.lease_kinds(&a, 1, 30.0, docker, 2.0).await?;
        assert_eq!(l.len(), 1, "{url}");
        assert!(
            store
                .refuse(&a, &l[0].lease_id, "no such image", 3.0)
                .await?
        );
        // A second refusal of the same lease is no longer the worker's.
        assert!(
            !store
                .refuse(&a, &l[0].lease_id, "no such image", 3.5)
                .await?
        );
        let eps = store.reader().episodes(&id).await?;
        assert_eq!(
            (eps[0].state.as_str(), eps[0].attempts),
            ("queued", 0),
            "{url}"
        );
        assert!(
            eps[0]
                .detail
                .as_deref()
                .unwrap_or("")
                .contains("no such image"),
            "{url}"
        );
        assert!(
            store
                .lease_kinds(&a, 1, 30.0, docker, 4.0)
                .await?
                .is_empty(),
            "{url}"
        );
        let l = store.lease_kinds(&b, 1, 30.0, docker, 5.0).await?;
        assert_eq!(l.len(), 1, "{url}: another worker takes it");
        assert_eq!(l[0].submission.id, id);
    }
    Ok(())
}
