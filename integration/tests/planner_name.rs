//! The name a planner announces in `Info` is checked as a submission's name is (issue 35): one with a bidirectional
//! override or a zero-width character, or longer than 100 characters, fails its episode at once as a protocol error
//! naming the field and the code point, over real processes (a worker, a coordinator, the example planner serving on
//! its own as an endpoint or started by the worker).

use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_announcing_a_name_that_cannot_be_shown_fails_as_a_protocol_error(
) -> anyhow::Result<()> {
    let dir = temp_dir("planner-name");
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
        &["--addr", &addr, "--name", "evil\u{202E}gnp.exe\u{200B}"],
    );
    wait_port(planner_port, Duration::from_secs(30));
    let mut c = client(port, &token).await;
    let endpoint = endpoint_submission("spoofer", &format!("http://{addr}"), &["w002-t0"]);
    let long = pb::SubmitRequest {
        name: "long-winded".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner {
                argv: vec![
                    example_planner().display().to_string(),
                    "--name".into(),
                    "n".repeat(101),
                ],
            })),
        }),
        task_ids: vec!["w002-t1".into()],
        ..Default::default()
    };
    for (req, why) in [
        (endpoint, "Info.name: character 5 is U+202E"),
        (
            long,
            "a name of 101 characters (Info.name); it must be at most 100",
        ),
    ] {
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
        assert!(e.detail.contains(why), "{}", e.detail);
        assert!(!e.detail.contains(['\u{202E}', '\u{200B}']), "{}", e.detail);
    }
    // The same planner with a plain name drives its episode.
    let planner_port = free_port();
    let addr = format!("127.0.0.1:{planner_port}");
    let _plain = Proc::start(
        "plain-planner",
        &dir,
        &example_planner(),
        &["--addr", &addr, "--name", "plain pure pursuit"],
    );
    wait_port(planner_port, Duration::from_secs(30));
    let id = vb_submit::submit(
        &mut c,
        endpoint_submission("plain", &format!("http://{addr}"), &["w002-t0"]),
    )
    .await?
    .submission_id;
    wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.state() == pb::SubmissionState::Done
    })
    .await;
    let r = vb_submit::results(&mut c, &id).await?;
    assert_ne!(
        r.episodes[0].reason(),
        pb::EndReason::PlannerProtocol,
        "{}",
        r.episodes[0].detail
    );
    Ok(())
}
