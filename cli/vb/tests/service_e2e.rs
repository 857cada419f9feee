//! End-to-end tests of the evaluation service over real gRPC and a real database, with every part a separate
//! process: `vb coordinator`, two `vb worker`s, `vb leaderboard`, and the example planner (started by the workers for
//! `exec` submissions, or by the test as an endpoint).

mod common;

use common::*;
use std::collections::BTreeMap;
use std::time::Duration;
use vb_proto::v1 as pb;

fn exec_request(name: &str, tasks: &[&str], args: &[&str], deadline: f64) -> pb::SubmitRequest {
    let mut argv = vec![example_planner().display().to_string()];
    argv.extend(args.iter().map(|s| s.to_string()));
    pb::SubmitRequest {
        name: name.into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner { argv })),
        }),
        task_ids: tasks.iter().map(|s| s.to_string()).collect(),
        step_deadline_s: deadline,
        ..Default::default()
    }
}

/// The step deadline of the planners that are not meant to time out: generous, so that a loaded 2-core machine (a
/// debug build, several workers and planner processes at once) cannot end a good episode as a planner failure.
const STEP_S: f64 = 5.0;

fn done(s: &pb::SubmissionStatus) -> bool {
    matches!(
        s.state(),
        pb::SubmissionState::Done | pb::SubmissionState::Cancelled
    )
}

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
    let http = free_port();
    let listen = format!("127.0.0.1:{http}");
    let _lb = Proc::start(
        "leaderboard",
        &dir,
        &vb(),
        &["leaderboard", "--db", &db, "--listen", &listen],
    );
    wait_port(http, Duration::from_secs(30));
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
    // The crash's stderr is kept with the episode and shown on its page.
    let http = free_port();
    let listen = format!("127.0.0.1:{http}");
    let _lb = Proc::start(
        "leaderboard",
        &dir,
        &vb(),
        &["leaderboard", "--db", &db, "--listen", &listen],
    );
    wait_port(http, Duration::from_secs(30));
    let page = http_text(
        http,
        &format!("/submissions/{}/episodes/w006-t0", crash.submission_id),
    );
    assert!(
        page.contains("id=\"log\"") && page.contains("crashing on purpose"),
        "{page}"
    );
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_requests_get_clear_errors_and_cancel_keeps_what_ran() -> anyhow::Result<()> {
    let dir = temp_dir("errors");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let url = format!("http://127.0.0.1:{port}");
    // Tokens.
    for bad in ["", "vbt_not-a-real-token"] {
        let mut c = vb_submit::connect(&url, if bad.is_empty() { " " } else { bad }, None).await?;
        let e = vb_submit::list(&mut c).await.unwrap_err().to_string();
        assert!(e.contains("authentication failed"), "{e}");
    }
    let mut c = client(port, &token).await;
    // Unknown ids.
    for e in [
        vb_submit::status(&mut c, "sub-nope")
            .await
            .unwrap_err()
            .to_string(),
        vb_submit::cancel(&mut c, "sub-nope")
            .await
            .unwrap_err()
            .to_string(),
        vb_submit::results(&mut c, "sub-nope")
            .await
            .unwrap_err()
            .to_string(),
    ] {
        assert!(e.contains("not found") && e.contains("sub-nope"), "{e}");
    }
    // Malformed submissions.
    let builtin = |b: &str| {
        Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Builtin(b.into())),
        })
    };
    let cases: Vec<(pb::SubmitRequest, &str)> = vec![
        (
            pb::SubmitRequest {
                name: "x".into(),
                ..Default::default()
            },
            "planner is missing",
        ),
        (
            pb::SubmitRequest {
                name: "".into(),
                planner: builtin("pid"),
                ..Default::default()
            },
            "name must be",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: builtin("teleport"),
                ..Default::default()
            },
            "unknown builtin planner `teleport`",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: builtin("pid"),
                vehicle: "tank-9000".into(),
                ..Default::default()
            },
            "vehicle",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: builtin("pid"),
                scale: -1.0,
                ..Default::default()
            },
            "scale",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: builtin("pid"),
                step_deadline_s: f64::NAN,
                ..Default::default()
            },
            "step_deadline_s",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: builtin("pid"),
                task_ids: vec!["w999-t0".into()],
                ..Default::default()
            },
            "not in the task set",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: builtin("pid"),
                task_ids: vec!["banana".into()],
                ..Default::default()
            },
            "is not `all`",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: Some(pb::PlannerRef {
                    kind: Some(pb::planner_ref::Kind::Endpoint("ftp://x".into())),
                }),
                ..Default::default()
            },
            "http://",
        ),
        (
            pb::SubmitRequest {
                name: "x".into(),
                planner: Some(pb::PlannerRef {
                    kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner {
                        argv: vec![],
                    })),
                }),
                ..Default::default()
            },
            "argv",
        ),
    ];
    for (req, needle) in cases {
        let e = vb_submit::submit(&mut c, req.clone())
            .await
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("invalid request") && e.contains(needle),
            "{req:?}: `{e}` lacks `{needle}`"
        );
    }
    // An oversized payload is refused, and the coordinator keeps serving.
    let huge = pb::SubmitRequest {
        name: "x".repeat(9 << 20),
        planner: builtin("pid"),
        ..Default::default()
    };
    let e = vb_submit::submit(&mut c, huge)
        .await
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("too large") || e.contains("message length"),
        "{e}"
    );
    assert!(
        vb_submit::list(&mut c).await?.is_empty(),
        "nothing was stored"
    );
    // The worker API wants a worker token on every call; a user's token is not one.
    let worker_token = create_token_with_role(&db, "rogue-test", "worker");
    fn authed<T>(msg: T, token: &str) -> tonic::Request<T> {
        let mut r = tonic::Request::new(msg);
        r.metadata_mut()
            .insert("authorization", format!("Bearer {token}").parse().unwrap());
        r
    }
    let register = |name: &str, sim: &str| pb::RegisterRequest {
        worker_name: name.into(),
        slots: 1,
        sim_version: sim.into(),
    };
    let mut w = pb::worker_pool_client::WorkerPoolClient::connect(url.clone()).await?;
    let e = w
        .register(register("anonymous", vb_worker::SIM_VERSION))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::Unauthenticated, "{e}");
    let e = w
        .register(authed(register("user", vb_worker::SIM_VERSION), &token))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    // ... it refuses a worker with another simulator version, and reports from workers it does not know under
    // this token.
    let e = w
        .register(authed(register("old", "sim-core 0.0.1"), &worker_token))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::FailedPrecondition, "{e}");
    let e = w
        .report_result(authed(
            pb::EpisodeReport {
                worker_id: "wk-nope".into(),
                outcome: pb::Outcome::Success.into(),
                ..Default::default()
            },
            &worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e}");
    let reg = w
        .register(authed(register("w", vb_worker::SIM_VERSION), &worker_token))
        .await?
        .into_inner();
    let other_worker_token = create_token_with_role(&db, "other", "worker");
    let e = w
        .lease(authed(
            pb::LeaseRequest {
                worker_id: reg.worker_id.clone(),
                max: 1,
                runs_exec_planners: true,
                runs_image_planners: false,
            },
            &other_worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(
        e.code(),
        tonic::Code::NotFound,
        "another token cannot use this worker: {e}"
    );
    // An outcome number the protocol does not define, or none (UNSPECIFIED), is refused.
    for (outcome, says) in [(99, "unknown outcome number 99"), (0, "no outcome given")] {
        let e = w
            .report_result(authed(
                pb::EpisodeReport {
                    worker_id: reg.worker_id.clone(),
                    outcome,
                    reason: pb::EndReason::Success.into(),
                    ..Default::default()
                },
                &worker_token,
            ))
            .await
            .unwrap_err();
        assert!(
            e.code() == tonic::Code::InvalidArgument && e.message().contains(says),
            "{e}"
        );
    }
    // A forged success for an episode this worker never leased is not taken, nor one with a bogus simulator
    // version or task set.
    let victim = vb_submit::submit(&mut c, exec_request("victim", &["9"], &[], 1.0)).await?;
    let forged = |sim: &str, set: &str| pb::EpisodeReport {
        worker_id: reg.worker_id.clone(),
        lease_id: "ls-forged".into(),
        submission_id: victim.submission_id.clone(),
        task_id: "w009-t0".into(),
        outcome: pb::Outcome::Success.into(),
        reason: pb::EndReason::Success.into(),
        sim_version: sim.into(),
        task_set_version: set.into(),
        metrics: Some((&sim_core::episode::EpisodeMetrics::default()).into()),
        ..Default::default()
    };
    let set_version = tasks::TaskSet::committed()?.version().to_string();
    let ack = w
        .report_result(authed(
            forged(vb_worker::SIM_VERSION, &set_version),
            &worker_token,
        ))
        .await?
        .into_inner();
    assert!(
        !ack.accepted && !ack.duplicate,
        "a report without the lease is rejected"
    );
    let e = w
        .report_result(authed(
            forged("sim-core 9.9.9", &set_version),
            &worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
    let e = w
        .report_result(authed(
            forged(vb_worker::SIM_VERSION, "0000000000000000"),
            &worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
    let results = vb_submit::results(&mut c, &victim.submission_id).await?;
    assert!(
        results
            .episodes
            .iter()
            .all(|e| e.outcome() != pb::Outcome::Success),
        "no forged result was stored (no worker has run the submission yet)"
    );
    // Another user's token neither sees nor cancels the submission; an admin's does.
    let mallory = create_token_with_role(&db, "mallory", "user");
    let mut m = client(port, &mallory).await;
    assert!(
        vb_submit::list(&mut m).await?.is_empty(),
        "mallory sees no one else's submissions"
    );
    for e in [
        vb_submit::status(&mut m, &victim.submission_id)
            .await
            .unwrap_err()
            .to_string(),
        vb_submit::cancel(&mut m, &victim.submission_id)
            .await
            .unwrap_err()
            .to_string(),
        vb_submit::results(&mut m, &victim.submission_id)
            .await
            .unwrap_err()
            .to_string(),
    ] {
        assert!(e.contains("no submission"), "{e}");
    }
    let admin = create_token_with_role(&db, "root", "admin");
    let mut a = client(port, &admin).await;
    assert!(vb_submit::list(&mut a)
        .await?
        .iter()
        .any(|s| s.submission_id == victim.submission_id));
    vb_submit::cancel(&mut a, &victim.submission_id).await?;

    // Cancel: finished episodes are kept, the rest is shown as not run. A slow planner and one worker slot.
    let _worker = start_worker(&dir, "worker", &db, port, 1);
    let sub = vb_submit::submit(
        &mut c,
        exec_request("slow", &["7"], &["--delay-ms", "3"], 1.0),
    )
    .await?;
    let id = sub.submission_id;
    wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.finished >= 2
    })
    .await;
    let s = vb_submit::cancel(&mut c, &id).await?;
    assert_eq!(s.state(), pb::SubmissionState::Cancelled);
    let s = wait_for(port, &token, &id, Duration::from_secs(60), |s| {
        s.running == 0
    })
    .await;
    assert!(
        s.finished >= 2 && s.not_run >= 1,
        "{}",
        vb_submit::status_line(&s)
    );
    assert_eq!(
        s.finished + s.not_run,
        10,
        "every episode is either finished or not run"
    );
    let r = vb_submit::results(&mut c, &id).await?;
    assert_eq!(
        r.episodes
            .iter()
            .filter(|e| e.state() == pb::EpisodeState::NotRun)
            .count() as u32,
        s.not_run
    );
    // vb eval's columns hold the finished episodes; the JSON lists the others with their state.
    let csv = vb_submit::results::csv(&r)?;
    assert_eq!(csv.lines().count(), 1 + s.finished as usize);
    let json: serde_json::Value = serde_json::from_str(&vb_submit::results::json(&r)?)?;
    let unfinished = json["unfinished"].as_array().expect("unfinished episodes");
    assert_eq!(unfinished.len(), s.not_run as usize);
    assert!(unfinished.iter().all(|e| e["state"] == "not_run"));
    assert_eq!(json["rules"], "paper");

    // An endpoint the user runs, and one that is not there.
    let pport = free_port();
    let paddr = format!("127.0.0.1:{pport}");
    let _planner = Proc::start(
        "endpoint-planner",
        &dir,
        &example_planner(),
        &["--addr", &paddr],
    );
    wait_port(pport, Duration::from_secs(30));
    let endpoint = |url: String, tasks: &[&str]| pb::SubmitRequest {
        name: url.clone(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Endpoint(url)),
        }),
        task_ids: tasks.iter().map(|s| s.to_string()).collect(),
        ..Default::default()
    };
    let up = vb_submit::submit(
        &mut c,
        endpoint(format!("http://{paddr}"), &["w008-t0", "w008-t1"]),
    )
    .await?;
    let down =
        vb_submit::submit(&mut c, endpoint("http://127.0.0.1:9".into(), &["w008-t2"])).await?;
    for s in [&up, &down] {
        wait_for(
            port,
            &token,
            &s.submission_id,
            Duration::from_secs(120),
            done,
        )
        .await;
    }
    let r = vb_submit::results(&mut c, &up.submission_id).await?;
    for e in &r.episodes {
        assert_ne!(
            e.outcome(),
            pb::Outcome::PlannerFailure,
            "{}: {}",
            e.task_id,
            e.detail
        );
        assert_eq!(e.planner_identity, format!("endpoint:http://{paddr}"));
    }
    let r = vb_submit::results(&mut c, &down.submission_id).await?;
    let e = &r.episodes[0];
    assert_eq!(
        (e.outcome(), e.reason()),
        (
            pb::Outcome::PlannerFailure,
            pb::EndReason::PlannerUnreachable
        ),
        "{}",
        e.detail
    );
    assert!(
        e.detail
            .contains("cannot connect to planner at http://127.0.0.1:9"),
        "{}",
        e.detail
    );
    Ok(())
}

/// The same service path on PostgreSQL (skipped, and said so, when no server is configured).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_submission_completes_on_postgres() -> anyhow::Result<()> {
    let Ok(admin) = std::env::var("VB_TEST_POSTGRES_URL") else {
        eprintln!("SKIPPED: VB_TEST_POSTGRES_URL is unset (.ci/run starts a PostgreSQL server and sets it)");
        return Ok(());
    };
    sqlx_free_create_db(&admin, "vbtest_e2e")?;
    let base = admin.rsplit_once('/').map_or(admin.as_str(), |(b, _)| b);
    let db = format!("{base}/vbtest_e2e");
    let dir = temp_dir("postgres");
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker(&dir, "worker", &db, port, 2);
    let mut c = client(port, &token).await;
    let req = pb::SubmitRequest {
        name: "pid on postgres".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Builtin("pid".into())),
        }),
        task_ids: vec!["8".into()],
        ..Default::default()
    };
    let id = vb_submit::submit(&mut c, req).await?.submission_id;
    let s = wait_for(port, &token, &id, Duration::from_secs(120), done).await;
    assert_eq!((s.state(), s.finished), (pb::SubmissionState::Done, 10));
    let http = free_port();
    let listen = format!("127.0.0.1:{http}");
    let _lb = Proc::start(
        "leaderboard",
        &dir,
        &vb(),
        &["leaderboard", "--db", &db, "--listen", &listen],
    );
    wait_port(http, Duration::from_secs(30));
    assert!(http_text(http, &format!("/submissions/{id}")).contains("id=\"by-density\""));
    Ok(())
}

/// Creates (or recreates) a database with `psql`, so this test needs no database driver of its own.
fn sqlx_free_create_db(admin: &str, name: &str) -> anyhow::Result<()> {
    for sql in [
        format!("DROP DATABASE IF EXISTS {name}"),
        format!("CREATE DATABASE {name}"),
    ] {
        let st = std::process::Command::new("psql")
            .args([admin, "-q", "-c", &sql])
            .status()?;
        anyhow::ensure!(st.success(), "psql {sql} failed");
    }
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_worker_that_leases_and_drops_is_throttled_and_uses_up_nothing() -> anyhow::Result<()> {
    let dir = temp_dir("rogue");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let rogue_token = create_token_with_role(&db, "rogue", "worker");
    let _coordinator = start_coordinator_with(
        &dir,
        "coordinator",
        &db,
        port,
        &["--max-dropped-leases", "3", "--drop-window-s", "600"],
    );
    let mut c = client(port, &token).await;
    let sub = vb_submit::submit(
        &mut c,
        pb::SubmitRequest {
            name: "victim".into(),
            planner: Some(pb::PlannerRef {
                kind: Some(pb::planner_ref::Kind::Builtin("pid".into())),
            }),
            task_ids: vec!["w001-t0".into(), "w001-t1".into()],
            ..Default::default()
        },
    )
    .await?;
    let url = format!("http://127.0.0.1:{port}");
    let mut w = pb::worker_pool_client::WorkerPoolClient::connect(url).await?;
    let call = |msg| {
        let mut r = tonic::Request::new(msg);
        r.metadata_mut().insert(
            "authorization",
            format!("Bearer {rogue_token}").parse().unwrap(),
        );
        r
    };
    let reg = w
        .register(call(pb::RegisterRequest {
            worker_name: "rogue".into(),
            slots: 1,
            sim_version: vb_worker::SIM_VERSION.into(),
        }))
        .await?
        .into_inner();
    // Lease one episode at a time and drop it (no heartbeat, no report), until the coordinator says no.
    let mut leased = 0;
    let t0 = std::time::Instant::now();
    let refusal = loop {
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "never throttled after {leased} leases"
        );
        let lease = pb::LeaseRequest {
            worker_id: reg.worker_id.clone(),
            max: 1,
            runs_exec_planners: false,
            runs_image_planners: false,
        };
        let mut r = tonic::Request::new(lease);
        r.metadata_mut().insert(
            "authorization",
            format!("Bearer {rogue_token}").parse().unwrap(),
        );
        match w.lease(r).await {
            Ok(r) => leased += r.into_inner().leases.len(),
            Err(e) => break e,
        }
        tokio::time::sleep(Duration::from_millis(500)).await;
    };
    assert_eq!(refusal.code(), tonic::Code::ResourceExhausted, "{refusal}");
    assert!(refusal.message().contains("throttled"), "{refusal}");
    assert!(leased >= 3, "{leased}");
    // Nothing of the submission was used up: both episodes are queued again, not failed.
    tokio::time::sleep(Duration::from_secs(4)).await;
    let s = vb_submit::status(&mut c, &sub.submission_id).await?;
    assert_eq!((s.finished, s.queued), (0, 2), "{s:?}");
    Ok(())
}
