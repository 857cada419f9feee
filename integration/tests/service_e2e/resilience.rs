//! Workers that die, restart or stop, and planners that misbehave: every task still gets exactly one result.

use crate::{done, exec_request, STEP_S};
use integration::*;
use std::collections::BTreeMap;
use std::time::Duration;
use vb_proto::v1 as pb;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workers_die_and_the_coordinator_restarts_yet_every_task_has_exactly_one_result(
) -> anyhow::Result<()> {
    let dir = temp_dir("kill");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let mut coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let mut worker_a = start_worker(&dir, "worker-a", &db, port, 2);
    let _worker_b = start_worker(&dir, "worker-b", &db, port, 2);
    let mut c = client(port, &token).await;
    // A slow but correct planner (5 ms per step), so episodes last long enough to be interrupted.
    let req = exec_request("example", &["1", "2"], &["--delay-ms", "5"], 2.0);
    let sub = vb_submit::submit(&mut c, req).await?;
    assert_eq!(sub.episodes, 20);
    let id = sub.submission_id.clone();

    // Kill worker A (SIGKILL) while it runs episodes.
    wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.finished >= 3
    })
    .await;
    worker_a.kill();
    // Kill the coordinator mid-run, then start it again on the same database and port.
    wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.finished >= 8
    })
    .await;
    coordinator.kill();
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let _coordinator2 = start_coordinator(&dir, "coordinator-restarted", &db, port);
    let last = wait_for(port, &token, &id, Duration::from_secs(300), done).await;
    assert_eq!(
        (last.state(), last.finished, last.total, last.not_run),
        (pb::SubmissionState::Done, 20, 20, 0)
    );

    let mut c = client(port, &token).await;
    let r = vb_submit::results(&mut c, &id).await?;
    let mut per_task: BTreeMap<String, usize> = BTreeMap::new();
    for e in &r.episodes {
        *per_task.entry(e.task_id.clone()).or_default() += 1;
        assert_eq!(e.state(), pb::EpisodeState::Done);
        assert_ne!(
            e.outcome(),
            pb::Outcome::InfrastructureError,
            "{}: lost to infrastructure: {}",
            e.task_id,
            e.detail
        );
        assert_ne!(
            e.outcome(),
            pb::Outcome::PlannerFailure,
            "{}: {:?} {}",
            e.task_id,
            e.reason(),
            e.detail
        );
        assert!(e.planner_identity.starts_with("exec:") && e.planner_identity.contains("sha256:"));
        assert!(e.metrics.is_some());
    }
    assert_eq!(per_task.len(), 20);
    assert!(per_task.values().all(|&n| n == 1), "{per_task:?}");
    // The killed worker's episodes were retried on the other one.
    assert!(
        r.episodes.iter().any(|e| e.attempts >= 2),
        "no episode was retried although worker A was killed mid-run"
    );

    // The leaderboard (a separate process reading the same store) shows the submission with its breakdowns.
    let (_lb, http) = start_leaderboard(&dir, &db);
    let index = http_text(http, "/");
    assert!(index.contains(&id) && index.contains("example"), "{index}");
    let page = http_text(http, &format!("/submissions/{id}"));
    for needle in [
        "id=\"by-level\"",
        "id=\"by-semantics\"",
        "id=\"by-density\"",
        "<svg",
        "id=\"repro\"",
        "sha256:",
        "w001-t0",
    ] {
        assert!(page.contains(needle), "submission page lacks {needle}");
    }
    let api_text = http_text(http, &format!("/api/submissions/{id}"));
    // The public sees the planner's kind and identity hash, never its command line.
    let command = example_planner().display().to_string();
    let episodes_api = http_text(http, &format!("/api/submissions/{id}/episodes"));
    for (what, text) in [
        ("/", &index),
        ("the submission page", &page),
        ("the API", &api_text),
        ("the episodes API", &episodes_api),
    ] {
        assert!(!text.contains(&command), "{what} shows the command line");
    }
    // Episodes come typed: a reason by its name, metrics as an object (not the stored JSON text).
    let eps: serde_json::Value = serde_json::from_str(&episodes_api)?;
    let eps = eps.as_array().expect("an array of episodes");
    assert_eq!(eps.len(), 20);
    for e in eps {
        let reason = e["reason"].as_str().expect("a reason");
        assert!(contracts::EndReason::parse(reason).is_ok(), "{reason}");
        assert!(
            e["metrics"]["time"].as_f64().is_some_and(|t| t > 0.0),
            "{e}"
        );
    }
    let api: serde_json::Value = serde_json::from_str(&api_text)?;
    assert_eq!(api["progress"]["finished"], 20);
    assert_eq!(api["summary"]["overall"]["episodes"], 20);
    assert!(api["summary"]["by_level"]
        .as_object()
        .is_some_and(|m| !m.is_empty()));
    let ep = http_text(http, &format!("/submissions/{id}/episodes/w002-t3"));
    for needle in [
        "id=\"trajectory\"",
        "id=\"roll-chart\"",
        "id=\"pitch-chart\"",
        "id=\"speed-chart\"",
        "/worlds/2.png",
    ] {
        assert!(ep.contains(needle), "episode page lacks {needle}");
    }
    // Every path of the OpenAPI document is served.
    let spec: serde_json::Value = serde_json::from_str(&http_text(http, "/api/openapi.json"))?;
    let paths = spec["paths"].as_object().expect("paths");
    assert!(paths.len() >= 5);
    for path in paths.keys() {
        let concrete = path
            .replace("{id}", &id)
            .replace("{task}", "w001-t0")
            .replace("{a}", &id)
            .replace("{b}", &id);
        let body = http_text(http, &concrete);
        serde_json::from_str::<serde_json::Value>(&body)
            .unwrap_or_else(|e| panic!("{concrete}: not JSON: {e}"));
    }
    let (code, png) = http_get(http, "/worlds/2.png");
    assert_eq!((code, &png[..4]), (200, &b"\x89PNG"[..]));
    let (code, body) = http_get(http, "/api/submissions/sub-nope");
    assert_eq!(code, 404, "{}", String::from_utf8_lossy(&body));
    assert!(String::from_utf8_lossy(&body).contains("no submission"));
    Ok(())
}

/// SIGTERM: a worker lets its running episodes finish within --drain-s and hands the rest back to the queue at once,
/// without using up their attempts or counting as dropped leases; another worker runs them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stopping_worker_hands_back_what_it_cannot_finish() -> anyhow::Result<()> {
    let dir = temp_dir("drain");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    // Leases of 3 s: were the episodes merely abandoned, they would come back only after that, as drops.
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let mut worker_a = start_worker_with(&dir, "worker-a", &db, port, 2, &["--drain-s", "0.3"]);
    let mut c = client(port, &token).await;
    // A slow planner (60 ms per step): its episodes last far longer than the drain.
    let req = exec_request("slow", &["1"], &["--delay-ms", "60"], 2.0);
    let id = vb_submit::submit(&mut c, req).await?.submission_id;
    // Two episodes running and two more leased, waiting for a slot.
    wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.running == 4
    })
    .await;
    assert!(
        worker_a.terminate(Duration::from_secs(10)),
        "the worker did not stop on SIGTERM:\n{}",
        worker_a.output()
    );
    assert!(
        worker_a.output().contains("finished=0 handed_back=4"),
        "{}",
        worker_a.output()
    );
    // Handed back at once: the running and the waiting episodes are queued again, long before their leases would have expired.
    let s = vb_submit::status(&mut c, &id).await?;
    assert_eq!((s.running, s.finished, s.queued), (0, 0, 10), "{s:?}");
    // No attempt used: every episode is as it was before any worker leased it.
    let r = vb_submit::results(&mut c, &id).await?;
    for e in &r.episodes {
        assert_eq!(
            (e.state(), e.attempts),
            (pb::EpisodeState::Queued, 0),
            "{}",
            e.task_id
        );
    }
    // Another worker takes them up at once.
    let _worker_b = start_worker(&dir, "worker-b", &db, port, 2);
    wait_for(port, &token, &id, Duration::from_secs(60), |s| {
        s.running == 4
    })
    .await;
    vb_submit::cancel(&mut c, &id).await?;
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn misbehaving_planners_fail_their_own_episodes_and_nothing_else() -> anyhow::Result<()> {
    let dir = temp_dir("faults");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _w1 = start_worker(&dir, "worker-1", &db, port, 3);
    let _w2 = start_worker(&dir, "worker-2", &db, port, 3);
    let mut c = client(port, &token).await;
    let good_tasks = ["w003-t0", "w003-t1", "w004-t2", "w005-t5"];
    // The well-behaved planner alone first, as the reference.
    let alone =
        vb_submit::submit(&mut c, exec_request("good alone", &good_tasks, &[], STEP_S)).await?;
    wait_for(
        port,
        &token,
        &alone.submission_id,
        Duration::from_secs(120),
        done,
    )
    .await;
    // Then again, side by side with four broken planners.
    let few = ["w006-t0", "w006-t1"];
    let good = vb_submit::submit(&mut c, exec_request("good", &good_tasks, &[], STEP_S)).await?;
    let crash = vb_submit::submit(
        &mut c,
        exec_request(
            "crash",
            &few,
            &["--fault", "crash", "--fault-after", "3"],
            STEP_S,
        ),
    )
    .await?;
    let hang = vb_submit::submit(
        &mut c,
        exec_request(
            "hang",
            &few,
            &["--fault", "hang", "--fault-after", "3"],
            0.3,
        ),
    )
    .await?;
    let nan = vb_submit::submit(
        &mut c,
        exec_request(
            "nan",
            &few,
            &["--fault", "nan", "--fault-after", "2"],
            STEP_S,
        ),
    )
    .await?;
    let range = vb_submit::submit(
        &mut c,
        exec_request("range", &few, &["--fault", "range"], STEP_S),
    )
    .await?;
    for s in [&good, &crash, &hang, &nan, &range] {
        wait_for(
            port,
            &token,
            &s.submission_id,
            Duration::from_secs(180),
            done,
        )
        .await;
    }
    let results = |id: String| {
        let token = token.clone();
        async move {
            let mut c = client(port, &token).await;
            vb_submit::results(&mut c, &id).await
        }
    };
    let expect = [
        (&crash, pb::EndReason::PlannerCrash, "crashing on purpose"),
        (&hang, pb::EndReason::PlannerTimeout, "within 0.300 s"),
        (&nan, pb::EndReason::InvalidAction, "steering is not finite"),
        (
            &range,
            pb::EndReason::InvalidAction,
            "throttle = 5 is outside",
        ),
    ];
    for (s, reason, detail) in expect {
        let r = results(s.submission_id.clone()).await?;
        assert_eq!(r.episodes.len(), 2);
        for e in &r.episodes {
            assert_eq!(
                (e.state(), e.outcome(), e.reason()),
                (pb::EpisodeState::Done, pb::Outcome::PlannerFailure, reason),
                "{}",
                e.detail
            );
            assert!(
                e.detail.contains(detail),
                "{reason:?}: detail `{}` lacks `{detail}`",
                e.detail
            );
            assert_eq!(e.attempts, 1, "a planner's own failure must not be retried");
        }
    }
    // The good planner got exactly the results it gets alone: same outcomes, same metrics, bit for bit.
    let a = results(alone.submission_id.clone()).await?;
    let g = results(good.submission_id.clone()).await?;
    assert_eq!(g.episodes.len(), good_tasks.len());
    for (x, y) in a.episodes.iter().zip(&g.episodes) {
        // Debug writes each f64 so that it reads back to the same bits (-0.0 included).
        assert_eq!(
            (&x.task_id, x.outcome, format!("{:?}", x.metrics)),
            (&y.task_id, y.outcome, format!("{:?}", y.metrics)),
            "details: alone `{}`, beside the broken planners `{}`",
            x.detail,
            y.detail
        );
        assert!(y.metrics.is_some());
        assert_ne!(y.outcome(), pb::Outcome::PlannerFailure);
    }
    // The crash's stderr is kept with the episode for its owner (above) and never on its public page (issue 58).
    let (_lb, http) = start_leaderboard(&dir, &db);
    let page = http_text(
        http,
        &format!("/submissions/{}/episodes/w006-t0", crash.submission_id),
    );
    assert!(
        page.contains("id=\"log\"") && !page.contains("crashing on purpose"),
        "{page}"
    );
    Ok(())
}
