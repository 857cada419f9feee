//! The coordinator's gRPC port (plaintext and TLS) and the `Sim` API of `vb worker --sim`: connections that send no
//! request, peers that answer no ping, quiet live connections, the connection limit, a submission under tight limits.

use crate::clients::*;
use integration::*;
use std::io::Write;
use std::path::Path;
use std::time::{Duration, Instant};
use vb_proto::v1 as pb;

/// Starts `vb coordinator` with `limits`.
fn coordinator(dir: &Path, db: &str, port: u16, limits: &[&str]) -> Proc {
    start_coordinator_with(dir, "coordinator", db, port, limits)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_coordinator_drops_connections_that_send_no_request_and_caps_its_connections() {
    let dir = temp_dir("grpc-first-request");
    let (db, token) = store(&dir);
    let port = free_port();
    // Idle 60 s and pings after 30 s (answered within 20 s): only the header timeout can close these within 10 s.
    let _c = coordinator(
        &dir,
        &db,
        port,
        &[
            "--header-timeout-s",
            "1",
            "--idle-timeout-s",
            "60",
            "--keepalive-s",
            "30",
            "--max-connections",
            "3",
        ],
    );
    let t = tokio::task::spawn_blocking(move || {
        let mut silent = connect(port);
        let mut partial = connect(port);
        partial.write_all(&PREFACE[..10]).expect("send");
        let mut preface_only = connect(port);
        preface_only.write_all(PREFACE).expect("send");
        preface_only.write_all(SETTINGS).expect("send");
        let mut trickled = connect(port);
        for (what, s, trickle) in [
            ("a silent connection", &mut silent, &b""[..]),
            ("a partial preface", &mut partial, &b""[..]),
            ("a preface without a request", &mut preface_only, &b""[..]),
            ("a preface sent a byte at a time", &mut trickled, PREFACE),
        ] {
            assert!(
                closed_within(s, CLOSED_BY, trickle).is_some(),
                "{what} is still open after {CLOSED_BY:?}"
            );
        }
    });
    t.await.expect("slow clients");
    // Normal gRPC works.
    let mut c = client(port, &token).await;
    vb_submit::list(&mut c).await.expect("list");
    drop(c);
    // Three live connections (they sent a request and answer pings) take every slot; a fourth is closed at once.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let path = "/vertibench.v1.Coordinator/ListSubmissions";
    let mut live = Vec::new();
    for _ in 0..3 {
        live.push(h2_client(port, path).await);
    }
    tokio::task::spawn_blocking(move || {
        let mut extra = connect(port);
        assert!(
            closed_within(&mut extra, CLOSED_BY, b"").is_some(),
            "a connection beyond the limit is still open after {CLOSED_BY:?}"
        );
    })
    .await
    .expect("extra");
    // The live ones still work; once they go, normal clients are served again.
    let mut again = Vec::new();
    for (send, driver) in live {
        again.push((h2_request(send, port, path).await.expect("live"), driver));
    }
    for (send, driver) in again {
        drop(send);
        driver.abort();
    }
    let t0 = Instant::now();
    loop {
        let ok = match vb_submit::connect(&format!("http://127.0.0.1:{port}"), &token, None).await {
            Ok(mut c) => vb_submit::list(&mut c).await.is_ok(),
            Err(_) => false,
        };
        if ok {
            break;
        }
        assert!(
            t0.elapsed() < CLOSED_BY,
            "the coordinator does not answer again"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_tls_coordinator_drops_stalled_handshakes_and_goes_on_serving() {
    let dir = temp_dir("tls-slow");
    if make_certificates(&dir).is_none() {
        eprintln!(
            "SKIPPED: the openssl command is not installed (it makes the test's certificates)"
        );
        return;
    }
    let (db, token) = store(&dir);
    let port = free_port();
    let (cert, key, ca) = (
        dir.join("server.pem").display().to_string(),
        dir.join("server.key").display().to_string(),
        dir.join("ca.pem"),
    );
    let _c = coordinator(
        &dir,
        &db,
        port,
        &[
            "--tls-cert",
            &cert,
            "--tls-key",
            &key,
            "--header-timeout-s",
            "1",
            "--idle-timeout-s",
            "60",
        ],
    );
    let url = format!("https://localhost:{port}");
    // Twice: a handshake that timed out must not stop the server from accepting the next connections.
    for round in 0..2 {
        tokio::task::spawn_blocking(move || {
            let mut silent = connect(port);
            // A TLS record header announcing a 512-byte ClientHello, and only its first bytes.
            let mut partial = connect(port);
            partial
                .write_all(&[0x16, 0x03, 0x01, 0x02, 0x00, 0x01, 0x00, 0x01, 0xfc])
                .expect("send");
            for (what, s) in [
                ("a silent connection", &mut silent),
                ("a partial ClientHello", &mut partial),
            ] {
                assert!(
                    closed_within(s, CLOSED_BY, b"").is_some(),
                    "round {round}: {what} to the TLS port is still open after {CLOSED_BY:?}"
                );
            }
        })
        .await
        .expect("stalled handshakes");
        let mut c = vb_submit::connect(&url, &token, Some(&ca))
            .await
            .unwrap_or_else(|e| panic!("round {round}: TLS client refused: {e}"));
        vb_submit::list(&mut c)
            .await
            .unwrap_or_else(|e| panic!("round {round}: {e}"));
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_coordinator_keeps_quiet_live_connections_drops_dead_peers_and_runs_a_submission() {
    let dir = temp_dir("grpc-keepalive");
    let (db, token) = store(&dir);
    let port = free_port();
    // The header timeout (60 s) is far above the bound; pings every second, answered within one.
    let _c = coordinator(
        &dir,
        &db,
        port,
        &[
            "--header-timeout-s",
            "60",
            "--idle-timeout-s",
            "4",
            "--keepalive-s",
            "1",
            "--keepalive-timeout-s",
            "1",
        ],
    );
    let path = "/vertibench.v1.Coordinator/ListSubmissions";
    // A peer that sent a request and then answers nothing (no pings): dropped.
    let dead = tokio::task::spawn_blocking(move || {
        let mut s = connect(port);
        s.write_all(PREFACE).expect("send");
        s.write_all(SETTINGS).expect("send");
        s.write_all(&headers_frame(path)).expect("send");
        closed_within(&mut s, CLOSED_BY, b"")
    });
    // A live peer quiet for twice the idle timeout keeps its connection (it answers the pings).
    let (send, driver) = h2_client(port, path).await;
    tokio::time::sleep(Duration::from_secs(8)).await;
    let send = h2_request(send, port, path)
        .await
        .expect("the quiet live connection was dropped");
    drop(send);
    driver.abort();
    assert!(
        dead.await.expect("dead peer").is_some(),
        "a peer that answers no ping is still connected after {CLOSED_BY:?}"
    );
    // Workers and submitters under these limits: a submission runs to the end.
    let _w = start_worker(&dir, "worker", &db, port, 2);
    let mut c = client(port, &token).await;
    let id = vb_submit::submit(
        &mut c,
        pb::SubmitRequest {
            name: "pid under tight limits".into(),
            planner: Some(pb::PlannerRef {
                kind: Some(pb::planner_ref::Kind::Builtin("pid".into())),
            }),
            task_ids: vec!["w001-t0".into(), "w001-t1".into()],
            ..Default::default()
        },
    )
    .await
    .expect("submit")
    .submission_id;
    let s = wait_for(port, &token, &id, Duration::from_secs(300), |s| {
        s.state() == pb::SubmissionState::Done
    })
    .await;
    assert_eq!(s.finished, 2, "{s:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_sim_api_of_a_worker_drops_silent_connections_and_caps_its_connections() {
    let dir = temp_dir("sim-limits");
    let (db, _) = store(&dir);
    let port = free_port();
    let _c = coordinator(&dir, &db, port, &[]);
    let sim_silent = free_port();
    let sim_capped = free_port();
    let silent_addr = format!("127.0.0.1:{sim_silent}");
    let capped_addr = format!("127.0.0.1:{sim_capped}");
    let _w1 = start_worker_with(
        &dir,
        "worker-sim-timeouts",
        &db,
        port,
        1,
        &["--sim", &silent_addr, "--header-timeout-s", "1"],
    );
    let _w2 = start_worker_with(
        &dir,
        "worker-sim-capped",
        &db,
        port,
        1,
        &["--sim", &capped_addr, "--max-connections", "2"],
    );
    wait_port(sim_silent, Duration::from_secs(60));
    wait_port(sim_capped, Duration::from_secs(60));
    tokio::task::spawn_blocking(move || {
        let mut silent = connect(sim_silent);
        let mut preface_only = connect(sim_silent);
        preface_only.write_all(PREFACE).expect("send");
        for (what, s) in [
            ("a silent connection", &mut silent),
            ("a preface without a request", &mut preface_only),
        ] {
            assert!(
                closed_within(s, CLOSED_BY, b"").is_some(),
                "{what} to the Sim API is still open after {CLOSED_BY:?}"
            );
        }
    })
    .await
    .expect("silent");
    tokio::time::sleep(Duration::from_millis(500)).await;
    let path = "/vertibench.v1.Sim/CloseEpisode";
    let live = vec![
        h2_client(sim_capped, path).await,
        h2_client(sim_capped, path).await,
    ];
    tokio::task::spawn_blocking(move || {
        let mut extra = connect(sim_capped);
        assert!(
            closed_within(&mut extra, CLOSED_BY, b"").is_some(),
            "a Sim connection beyond the limit is still open after {CLOSED_BY:?}"
        );
    })
    .await
    .expect("extra");
    for (send, driver) in live {
        drop(send);
        driver.abort();
    }
    // A normal client is served again: an episode is created and closed.
    let t0 = Instant::now();
    loop {
        if let Ok(mut sim) =
            pb::sim_client::SimClient::connect(format!("http://127.0.0.1:{sim_capped}")).await
        {
            if let Ok(r) = sim
                .create_episode(pb::CreateEpisodeRequest {
                    task_id: "w001-t0".into(),
                    ..Default::default()
                })
                .await
            {
                let id = r.into_inner().episode_id;
                sim.close_episode(pb::CloseEpisodeRequest { episode_id: id })
                    .await
                    .expect("close");
                break;
            }
        }
        assert!(
            t0.elapsed() < CLOSED_BY,
            "the Sim API does not answer again"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// Issue 58, point 1, against a gRPC port: one client holding every connection it can with a preface it never
/// finishes gets its address's share, and head-less connections from many addresses make way for new clients; a
/// fresh client's request (`path`) from another address is answered throughout.
async fn attack_grpc(port: u16, path: &str, server: &str) {
    for (attackers, what) in [(1..=1u8, "one client"), (3..=10u8, "many addresses")] {
        let threads: Vec<_> = attackers
            .map(|ip| {
                let hold = if ip == 1 { 60 } else { 10 };
                std::thread::spawn(move || {
                    hold_partial_heads(ip, port, hold, &PREFACE[..10], Duration::from_secs(6))
                })
            })
            .collect();
        tokio::time::sleep(Duration::from_secs(1)).await;
        let mut answered = 0;
        for _ in 0..20 {
            tokio::time::sleep(Duration::from_millis(100)).await;
            answered += usize::from(h2_answered_from(2, port, path).await);
        }
        for t in threads {
            t.join().expect("attacker");
        }
        assert_eq!(
            answered,
            20,
            "{server}: {} of 20 fresh gRPC requests went unanswered under a flood from {what}",
            20 - answered
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_grpc_client_cannot_lock_others_out_and_headless_floods_make_way() {
    let dir = temp_dir("conn-share-grpc");
    let (db, _) = store(&dir);
    let port = free_port();
    let _c = coordinator(&dir, &db, port, &SHARE_LIMITS);
    wait_port(port, Duration::from_secs(60));
    attack_grpc(
        port,
        "/vertibench.v1.Coordinator/ListSubmissions",
        "the coordinator",
    )
    .await;
    // A worker's Sim port accepts through the same guard (as vb serve's ports do: vb_serve_applies_its_limits_...).
    let sim = free_port();
    let sim_addr = format!("127.0.0.1:{sim}");
    let mut args = vec!["--sim", sim_addr.as_str()];
    args.extend_from_slice(&SHARE_LIMITS);
    let _w = start_worker_with(&dir, "worker-share", &db, port, 1, &args);
    wait_port(sim, Duration::from_secs(60));
    attack_grpc(sim, "/vertibench.v1.Sim/CloseEpisode", "the Sim API").await;
}

/// Issue 58, point 3, over real processes: `vb worker --sim` with tokens (VB_SIM_TOKEN) refuses a call without one
/// or with another, and serves one with a listed token.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_sim_api_of_a_worker_takes_only_its_tokens() {
    let dir = temp_dir("sim-token");
    let (db, _) = store(&dir);
    let port = free_port();
    let _c = coordinator(&dir, &db, port, &[]);
    let sim = free_port();
    let url = format!("http://127.0.0.1:{port}");
    let sim_addr = format!("127.0.0.1:{sim}");
    let worker_token = create_token_with_role(&db, "worker-sim-token", "worker");
    let _w = Proc::start_env(
        "worker-sim-token",
        &dir,
        &vb(),
        &[
            "worker",
            "--coordinator",
            &url,
            "--slots",
            "1",
            "--sim",
            &sim_addr,
        ],
        &[
            ("VB_WORKER_TOKEN", &worker_token),
            ("VB_SIM_TOKEN", "sim-secret-1,sim-secret-2"),
        ],
    );
    wait_port(sim, Duration::from_secs(60));
    let mut c = pb::sim_client::SimClient::connect(format!("http://{sim_addr}"))
        .await
        .expect("connect");
    let create = |token: Option<&str>| {
        let mut r = tonic::Request::new(pb::CreateEpisodeRequest {
            task_id: "w001-t0".into(),
            ..Default::default()
        });
        if let Some(t) = token {
            r.metadata_mut().insert(
                "authorization",
                format!("Bearer {t}").parse().expect("header"),
            );
        }
        r
    };
    for token in [None, Some("guess")] {
        let e = c
            .create_episode(create(token))
            .await
            .expect_err("served without its token");
        assert_eq!(e.code(), tonic::Code::Unauthenticated, "{e:?}");
    }
    let id = c
        .create_episode(create(Some("sim-secret-2")))
        .await
        .expect("a listed token")
        .into_inner()
        .episode_id;
    let mut close = tonic::Request::new(pb::CloseEpisodeRequest { episode_id: id });
    close.metadata_mut().insert(
        "authorization",
        "Bearer sim-secret-2".parse().expect("header"),
    );
    c.close_episode(close).await.expect("close");
}
