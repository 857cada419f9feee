//! Issue 35's input hardening over real processes and real gRPC: a stolen worker token that leases and hands back
//! in a loop is throttled; tokens' roles are kept apart on both APIs; submissions with malformed endpoints, flag-like
//! image references, or names with bidirectional and invisible characters are refused with messages that say why;
//! repeated task selections are accepted once each; a planner that announces a bad control rate fails its episode as
//! a protocol error that says so.

use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;

fn authed<T>(msg: T, token: &str) -> tonic::Request<T> {
    let mut r = tonic::Request::new(msg);
    r.metadata_mut()
        .insert("authorization", format!("Bearer {token}").parse().unwrap());
    r
}

fn builtin(name: &str, tasks: &[&str]) -> pb::SubmitRequest {
    pb::SubmitRequest {
        name: format!("{name} (test)"),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Builtin(name.into())),
        }),
        task_ids: tasks.iter().map(|s| s.to_string()).collect(),
        ..Default::default()
    }
}

fn register(name: &str) -> pb::RegisterRequest {
    pb::RegisterRequest {
        worker_name: name.into(),
        slots: 1,
        sim_version: vb_worker::SIM_VERSION.into(),
    }
}

fn lease(worker_id: &str) -> pb::LeaseRequest {
    pb::LeaseRequest {
        worker_id: worker_id.into(),
        max: 1,
        runs_exec_planners: false,
        runs_image_planners: false,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_token_that_leases_and_hands_back_in_a_loop_is_throttled() -> anyhow::Result<()> {
    let dir = temp_dir("hand-back-loop");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let rogue = create_token_with_role(&db, "rogue", "worker");
    let honest = create_token_with_role(&db, "honest", "worker");
    let _coordinator = start_coordinator_with(
        &dir,
        "coordinator",
        &db,
        port,
        &["--max-handed-back-leases", "5", "--drop-window-s", "600"],
    );
    let mut c = client(port, &token).await;
    let sub = vb_submit::submit(&mut c, builtin("pid", &["w001-t0", "w001-t1"]))
        .await?
        .submission_id;
    let url = format!("http://127.0.0.1:{port}");
    let mut w = pb::worker_pool_client::WorkerPoolClient::connect(url).await?;
    let reg = w
        .register(authed(register("rogue"), &rogue))
        .await?
        .into_inner();
    // Lease and hand back at once, as fast as the coordinator answers, until it says no.
    let mut leased = 0;
    let refusal = loop {
        assert!(leased <= 100, "never throttled after {leased} leases");
        match w.lease(authed(lease(&reg.worker_id), &rogue)).await {
            Ok(r) => {
                for l in r.into_inner().leases {
                    leased += 1;
                    let back = pb::EpisodeReport {
                        worker_id: reg.worker_id.clone(),
                        lease_id: l.lease_id.clone(),
                        submission_id: l.submission_id.clone(),
                        task_id: l.task_id.clone(),
                        unscored: Some(pb::episode_report::Unscored::HandedBack(true)),
                        ..Default::default()
                    };
                    w.report_result(authed(back, &rogue)).await?;
                }
            }
            Err(e) => break e,
        }
    };
    assert_eq!(refusal.code(), tonic::Code::ResourceExhausted, "{refusal}");
    assert!(
        refusal.message().contains("throttled") && refusal.message().contains("handed back 5"),
        "{refusal}"
    );
    assert_eq!(leased, 5, "the budget is 5 hand-backs in the window");
    // Still refused on the next call: the window has not passed.
    let again = w
        .lease(authed(lease(&reg.worker_id), &rogue))
        .await
        .unwrap_err();
    assert_eq!(again.code(), tonic::Code::ResourceExhausted, "{again}");
    // A hand-back still uses no attempt: both episodes are queued as if never leased.
    let r = vb_submit::results(&mut c, &sub).await?;
    for e in &r.episodes {
        assert_eq!(
            (e.state(), e.attempts),
            (pb::EpisodeState::Queued, 0),
            "{}",
            e.task_id
        );
    }
    // The throttle is the rogue token's alone: another worker token leases at once.
    let other = w
        .register(authed(register("honest"), &honest))
        .await?
        .into_inner();
    let got = w
        .lease(authed(lease(&other.worker_id), &honest))
        .await?
        .into_inner();
    assert_eq!(got.leases.len(), 1);
    // Refusing instead of handing back (a new worker id each time, since a worker that refused a submission is not
    // leased it again) is given back unrun all the same, and throttled all the same.
    let refuser = create_token_with_role(&db, "refuser", "worker");
    let mut refused = 0;
    let refusal = loop {
        assert!(refused <= 100, "never throttled after {refused} refusals");
        let me = w
            .register(authed(register("refuser"), &refuser))
            .await?
            .into_inner();
        match w.lease(authed(lease(&me.worker_id), &refuser)).await {
            Ok(r) => {
                for l in r.into_inner().leases {
                    refused += 1;
                    let no = pb::EpisodeReport {
                        worker_id: me.worker_id.clone(),
                        lease_id: l.lease_id.clone(),
                        submission_id: l.submission_id.clone(),
                        task_id: l.task_id.clone(),
                        unscored: Some(pb::episode_report::Unscored::CannotRun(true)),
                        detail: "no such image".into(),
                        ..Default::default()
                    };
                    w.report_result(authed(no, &refuser)).await?;
                }
            }
            Err(e) => break e,
        }
    };
    assert_eq!(refusal.code(), tonic::Code::ResourceExhausted, "{refusal}");
    assert_eq!(refused, 5, "the budget is 5 given back in the window");
    vb_submit::cancel(&mut c, &sub).await?;
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn roles_are_kept_apart_on_both_apis() -> anyhow::Result<()> {
    let dir = temp_dir("roles");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let admin = create_token_with_role(&db, "root", "admin");
    let worker = create_token_with_role(&db, "machine", "worker");
    let user = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let url = format!("http://127.0.0.1:{port}");
    let mut w = pb::worker_pool_client::WorkerPoolClient::connect(url.clone()).await?;
    // An admin's token is not a worker token: every call of the worker API refuses it.
    let e = w
        .register(authed(register("admin-as-worker"), &admin))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    assert!(e.message().contains("needs a worker token"), "{e}");
    let reg = w
        .register(authed(register("real"), &worker))
        .await?
        .into_inner();
    let e = w
        .lease(authed(lease(&reg.worker_id), &admin))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    let e = w
        .heartbeat(authed(
            pb::HeartbeatRequest {
                worker_id: reg.worker_id.clone(),
                lease_ids: vec![],
            },
            &admin,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    let e = w
        .report_result(authed(
            pb::EpisodeReport {
                worker_id: reg.worker_id.clone(),
                unscored: Some(pb::episode_report::Unscored::HandedBack(true)),
                ..Default::default()
            },
            &admin,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    // A user's token neither.
    let e = w
        .lease(authed(lease(&reg.worker_id), &user))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    // The worker token works on the worker API ...
    w.lease(authed(lease(&reg.worker_id), &worker)).await?;
    // ... and not on the submission API.
    let mut s = pb::coordinator_client::CoordinatorClient::connect(url).await?;
    let e = s
        .submit(authed(builtin("pid", &["w001-t0"]), &worker))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    let e = s
        .list_submissions(authed(pb::ListRequest::default(), &worker))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    // The admin's token is for the submission API.
    s.submit(authed(builtin("pid", &["w001-t0"]), &admin))
        .await?;
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn submissions_are_validated_strictly() -> anyhow::Result<()> {
    let dir = temp_dir("strict");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let mut c = client(port, &token).await;
    let planner = |kind| Some(pb::PlannerRef { kind: Some(kind) });
    let named = |name: &str| pb::SubmitRequest {
        name: name.into(),
        ..builtin("pid", &["w001-t0"])
    };
    let cases: Vec<(pb::SubmitRequest, &[&str])> = vec![
        (
            pb::SubmitRequest {
                planner: planner(pb::planner_ref::Kind::Endpoint("http://[bad".into())),
                ..builtin("pid", &[])
            },
            &["endpoint `http://[bad`", "invalid IPv6 address"],
        ),
        (
            pb::SubmitRequest {
                planner: planner(pb::planner_ref::Kind::Endpoint("http://".into())),
                ..builtin("pid", &[])
            },
            &["endpoint `http://`", "empty host"],
        ),
        (
            pb::SubmitRequest {
                planner: planner(pb::planner_ref::Kind::Image("--privileged".into())),
                ..builtin("pid", &[])
            },
            &["image: `--privileged`", "starts with `-`"],
        ),
        (
            pb::SubmitRequest {
                planner: planner(pb::planner_ref::Kind::Image("Ubuntu:latest".into())),
                ..builtin("pid", &[])
            },
            &["image: `Ubuntu:latest`", "name component `Ubuntu`"],
        ),
        (
            named("evil\u{202E}gnp.exe"),
            &["name: character 5 is U+202E", "bidirectional"],
        ),
        (named("pi\u{200B}d"), &["name: ", "U+200B", "zero-width"]),
        (named("\u{2066}pid\u{2069}"), &["name: ", "U+2066"]),
        (named("pid\u{FEFF}"), &["name: ", "U+FEFF"]),
    ];
    for (req, needles) in cases {
        let e = c.submit(req.clone()).await.unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{req:?}: {e}");
        for n in needles {
            assert!(
                e.message().contains(n),
                "{req:?}: `{}` lacks `{n}`",
                e.message()
            );
        }
    }
    assert!(vb_submit::list(&mut c).await?.is_empty(), "nothing stored");
    // Repeated selections are a union: `all,all` is every task once; repeated ids are one episode each.
    let all = vb_submit::submit(&mut c, builtin("pid", &["all", "all"])).await?;
    let set = tasks::TaskSet::committed()?;
    let s = vb_submit::status(&mut c, &all.submission_id).await?;
    assert_eq!(s.total as usize, 10 * set.world_ids().len(), "{s:?}");
    let some = vb_submit::submit(
        &mut c,
        builtin("pid", &["w001-t0", "w001-t0", "1", "w002-t3"]),
    )
    .await?;
    let r = vb_submit::results(&mut c, &some.submission_id).await?;
    let ids: Vec<&str> = r.episodes.iter().map(|e| e.task_id.as_str()).collect();
    assert_eq!(ids.len(), 11, "{ids:?}");
    assert_eq!(
        ids.iter().filter(|t| **t == "w001-t0").count(),
        1,
        "{ids:?}"
    );
    // Valid endpoint and image references still pass (no worker runs them here).
    for kind in [
        pb::planner_ref::Kind::Endpoint("http://127.0.0.1:9".into()),
        pb::planner_ref::Kind::Image("ghcr.io/org/planner:v1".into()),
    ] {
        let req = pb::SubmitRequest {
            planner: planner(kind),
            ..builtin("pid", &["w001-t0"])
        };
        let ok = vb_submit::submit(&mut c, req).await?;
        vb_submit::cancel(&mut c, &ok.submission_id).await?;
    }
    for id in [all.submission_id, some.submission_id] {
        vb_submit::cancel(&mut c, &id).await?;
    }
    Ok(())
}

/// A planner that announces a control rate out of range fails its episode at once as a protocol error naming the
/// rate, whether the worker started it (exec) or it serves on its own (endpoint); it is not waited for until the
/// startup timeout and not reported as unreachable.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_announcing_a_bad_control_rate_fails_as_a_protocol_error() -> anyhow::Result<()> {
    let dir = temp_dir("bad-rate");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker(&dir, "worker", &db, port, 2);
    let planner_port = free_port();
    let addr = format!("127.0.0.1:{planner_port}");
    let _endpoint = Proc::start(
        "endpoint-planner",
        &dir,
        &example_planner(),
        &["--addr", &addr, "--control-rate-hz", "0"],
    );
    wait_port(planner_port, Duration::from_secs(30));
    let mut c = client(port, &token).await;
    let exec = pb::SubmitRequest {
        name: "fast talker".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner {
                argv: vec![
                    example_planner().display().to_string(),
                    "--control-rate-hz".into(),
                    "5000".into(),
                ],
            })),
        }),
        task_ids: vec!["w002-t0".into()],
        ..Default::default()
    };
    let endpoint = endpoint_submission("still", &format!("http://{addr}"), &["w002-t1"]);
    for (req, rate) in [(exec, "5000"), (endpoint, "0")] {
        let id = vb_submit::submit(&mut c, req).await?.submission_id;
        wait_for(port, &token, &id, Duration::from_secs(120), |s| {
            s.state() == pb::SubmissionState::Done
        })
        .await;
        let r = vb_submit::results(&mut c, &id).await?;
        let e = &r.episodes[0];
        assert_eq!(
            (e.outcome(), e.reason(), e.attempts),
            (
                pb::Outcome::PlannerFailure,
                pb::EndReason::PlannerProtocol,
                1
            ),
            "{}",
            e.detail
        );
        assert!(
            e.detail
                .contains(&format!("planner announced control rate {rate} Hz"))
                && e.detail.contains("must be in (0, 1000] Hz")
                && !e.detail.contains("did not serve"),
            "{}",
            e.detail
        );
    }
    Ok(())
}
