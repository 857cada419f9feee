//! Bad requests get clear errors; another user's token sees nothing; cancel keeps what ran; endpoints the user
//! runs, and one that is not there.

use crate::{done, exec_request};
use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;

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
    unknown_ids_and_malformed_submissions(&mut c).await?;
    let victim =
        crate::worker_api::refuses_what_no_leased_worker_may_do(&url, &db, &token, &mut c).await?;
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
    let up_url = format!("http://{paddr}");
    let up = vb_submit::submit(
        &mut c,
        endpoint_submission(&up_url, &up_url, &["w008-t0", "w008-t1"]),
    )
    .await?;
    let down_url = "http://127.0.0.1:9";
    let down = vb_submit::submit(
        &mut c,
        endpoint_submission(down_url, down_url, &["w008-t2"]),
    )
    .await?;
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

/// Unknown ids, malformed and oversized submissions: each refused with a message that names the problem, and
/// nothing stored.
async fn unknown_ids_and_malformed_submissions(c: &mut vb_submit::Client) -> anyhow::Result<()> {
    // Unknown ids.
    for e in [
        vb_submit::status(c, "sub-nope")
            .await
            .unwrap_err()
            .to_string(),
        vb_submit::cancel(c, "sub-nope")
            .await
            .unwrap_err()
            .to_string(),
        vb_submit::results(c, "sub-nope")
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
        let e = vb_submit::submit(c, req.clone())
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
    let e = vb_submit::submit(c, huge).await.unwrap_err().to_string();
    assert!(
        e.contains("too large") || e.contains("message length"),
        "{e}"
    );
    assert!(vb_submit::list(c).await?.is_empty(), "nothing was stored");
    Ok(())
}
