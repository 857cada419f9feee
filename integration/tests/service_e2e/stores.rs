//! The service on PostgreSQL, and workers that lease and drop.

use crate::done;
use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;

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
