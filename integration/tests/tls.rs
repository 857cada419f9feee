//! The coordinator over TLS (`vb coordinator --tls-cert --tls-key`): a worker and a submitter that trust the
//! cluster's CA run an evaluation through it; a plaintext client and a client that does not trust the CA get
//! nothing. The certificates are made with the `openssl` command for the test (skipped, and said so, without it).

use integration::*;
use std::time::{Duration, Instant};
use vb_proto::v1 as pb;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_evaluation_runs_over_tls_and_nothing_else_gets_in() -> anyhow::Result<()> {
    let dir = temp_dir("tls");
    if make_certificates(&dir).is_none() {
        eprintln!(
            "SKIPPED: the openssl command is not installed (it makes the test's certificates)"
        );
        return Ok(());
    }
    let (cert, key, ca) = (
        dir.join("server.pem"),
        dir.join("server.key"),
        dir.join("ca.pem"),
    );
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator_with(
        &dir,
        "coordinator",
        &db,
        port,
        &[
            "--tls-cert",
            &cert.display().to_string(),
            "--tls-key",
            &key.display().to_string(),
        ],
    );
    let url = format!("https://localhost:{port}");
    let worker_token = create_token_with_role(&db, "tls-worker", "worker");
    let _worker = Proc::start_env(
        "worker",
        &dir,
        &vb(),
        &[
            "worker",
            "--coordinator",
            &url,
            "--tls-ca",
            &ca.display().to_string(),
            "--slots",
            "2",
        ],
        &[("VB_WORKER_TOKEN", &worker_token)],
    );
    let mut c = vb_submit::connect(&url, &token, Some(&ca)).await?;
    let req = pb::SubmitRequest {
        name: "pid over tls".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Builtin("pid".into())),
        }),
        task_ids: vec!["w008-t0".into(), "w008-t1".into()],
        ..Default::default()
    };
    let id = vb_submit::submit(&mut c, req).await?.submission_id;
    let t0 = Instant::now();
    let status = loop {
        let s = vb_submit::status(&mut c, &id).await?;
        if s.state() == pb::SubmissionState::Done {
            break s;
        }
        assert!(
            t0.elapsed() < Duration::from_secs(120),
            "not done: {}",
            vb_submit::status_line(&s)
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    assert_eq!(status.finished, 2, "the worker ran both episodes over TLS");

    // Plaintext to the TLS port: refused.
    let plain = match vb_submit::connect(&format!("http://127.0.0.1:{port}"), &token, None).await {
        Ok(mut c) => vb_submit::status(&mut c, &id)
            .await
            .map(|_| ())
            .map_err(|e| e.to_string()),
        Err(e) => Err(e.to_string()),
    };
    assert!(plain.is_err(), "a plaintext client was answered");
    // TLS without trusting the cluster's CA (the public roots only): the server's certificate is refused.
    let untrusted = vb_submit::connect(&url, &token, None)
        .await
        .map(|_| ())
        .map_err(|e| e.to_string());
    let e = untrusted.expect_err("a client that does not trust the CA connected");
    assert!(
        e.to_lowercase().contains("certificate") || e.contains("UnknownIssuer"),
        "{e}"
    );
    // A CA file given for a plaintext URL is a usage error, not a silent downgrade.
    let e = vb_submit::connect(&format!("http://127.0.0.1:{port}"), &token, Some(&ca))
        .await
        .map(|_| ())
        .expect_err("a CA with http:// was accepted");
    assert!(e.to_string().contains("https://"), "{e}");
    Ok(())
}
