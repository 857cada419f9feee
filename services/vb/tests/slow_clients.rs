//! Slow and silent clients against every network server, as real `vb` processes with small limits set by flags
//! (issue 35, point 5): the leaderboard (`vb leaderboard`, `vb serve --http`), the coordinator's gRPC port (`vb
//! coordinator`, `vb serve --grpc`) and the `Sim` API (`vb worker --sim`).
//!
//! Nothing here measures speed: a connection must be closed within a generous bound (10 s for a 1 s timeout) that
//! is far below the limits that must not be what closed it.

mod common;

use common::*;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};
use vb_proto::v1 as pb;

/// The bound within which a connection past a 1 s timeout must have been closed.
const CLOSED_BY: Duration = Duration::from_secs(10);
/// The HTTP/2 client preface.
const PREFACE: &[u8] = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";
/// An empty SETTINGS frame.
const SETTINGS: &[u8] = &[0, 0, 0, 4, 0, 0, 0, 0, 0];

fn connect(port: u16) -> TcpStream {
    let s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    s.set_read_timeout(Some(Duration::from_millis(100))).ok();
    s
}

/// Reads (discarding what the server sends) and, every 200 ms, writes the next byte of `trickle`, until the server
/// closes the connection; how long that took, or `None` if it was still open after `limit`.
fn closed_within(s: &mut TcpStream, limit: Duration, trickle: &[u8]) -> Option<Duration> {
    let t0 = Instant::now();
    let mut next = 0;
    let mut last_write = t0;
    let mut buf = [0u8; 4096];
    while t0.elapsed() < limit {
        match s.read(&mut buf) {
            Ok(0) => return Some(t0.elapsed()),
            Ok(_) => {}
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
            Err(_) => return Some(t0.elapsed()),
        }
        if next < trickle.len() && last_write.elapsed() >= Duration::from_millis(200) {
            if s.write_all(&trickle[next..next + 1]).is_err() {
                return Some(t0.elapsed());
            }
            next += 1;
            last_write = Instant::now();
        }
    }
    None
}

/// Whether the server still holds `s` open: nothing to read, no EOF, within a short look.
fn still_open(s: &mut TcpStream) -> bool {
    let mut buf = [0u8; 1];
    s.set_nonblocking(true).ok();
    let open = matches!(s.read(&mut buf), Err(e) if e.kind() == ErrorKind::WouldBlock);
    s.set_nonblocking(false).ok();
    open
}

fn open_fds(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd")).map_or(0, |d| d.count())
}

fn start_leaderboard(dir: &Path, name: &str, db: &str, port: u16, limits: &[&str]) -> Proc {
    let listen = format!("127.0.0.1:{port}");
    let mut args = vec!["leaderboard", "--db", db, "--listen", &listen];
    args.extend_from_slice(limits);
    let p = Proc::start(name, dir, &vb(), &args);
    wait_port(port, Duration::from_secs(30));
    p
}

/// A store with one user token (which also creates the store).
fn store(dir: &Path) -> (String, String) {
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    (db, token)
}

/// The status of GET / on a fresh connection, or `None` if the server closed it without an answer.
fn try_get(port: u16) -> Option<u16> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(30))).ok();
    s.write_all(b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
        .ok()?;
    let mut head = [0u8; 12];
    s.read_exact(&mut head).ok()?;
    std::str::from_utf8(&head[9..12]).ok()?.parse().ok()
}

/// GET / until it answers 200 (the server may still be closing the connections a test let go).
fn get_ok_within(port: u16, limit: Duration) {
    let t0 = Instant::now();
    loop {
        let answered = try_get(port);
        if answered == Some(200) {
            return;
        }
        assert!(t0.elapsed() < limit, "GET / not answered: {answered:?}");
        std::thread::sleep(Duration::from_millis(200));
    }
}

#[test]
fn the_leaderboard_drops_slow_headers_and_kept_alive_connections_after_the_header_timeout() {
    let dir = temp_dir("slow-headers");
    let (db, _) = store(&dir);
    let port = free_port();
    // The idle timeout (60 s) is far above the bound: only the header timeout can close these.
    let _lb = start_leaderboard(
        &dir,
        "leaderboard",
        &db,
        port,
        &["--header-timeout-s", "1", "--idle-timeout-s", "60"],
    );
    // Slowloris: a request line and a header, then one more byte of headers every 200 ms, never the blank line.
    let trickle = b"X-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa";
    let mut slow: Vec<TcpStream> = (0..20)
        .map(|_| {
            let mut s = connect(port);
            s.write_all(b"GET / HTTP/1.1\r\nHost: localhost\r\n")
                .expect("send");
            s
        })
        .collect();
    for (i, s) in slow.iter_mut().enumerate() {
        assert!(
            closed_within(s, CLOSED_BY, trickle).is_some(),
            "slow-header connection {i} still open after {CLOSED_BY:?}"
        );
    }
    // A kept-alive connection that asks nothing more after its answer is closed too.
    let mut kept = connect(port);
    kept.write_all(b"GET /api/submissions HTTP/1.1\r\nHost: localhost\r\n\r\n")
        .expect("send");
    let mut head = [0u8; 12];
    kept.set_read_timeout(Some(Duration::from_secs(30))).ok();
    kept.read_exact(&mut head).expect("an answer");
    assert_eq!(&head, b"HTTP/1.1 200", "{}", String::from_utf8_lossy(&head));
    kept.set_read_timeout(Some(Duration::from_millis(100))).ok();
    assert!(
        closed_within(&mut kept, CLOSED_BY, b"").is_some(),
        "a kept-alive connection with no next request is still open after {CLOSED_BY:?}"
    );
    // The server answers normal requests all along.
    assert_eq!(http_get(port, "/").0, 200);
}

#[test]
fn the_leaderboard_closes_silent_connections_after_the_idle_timeout() {
    let dir = temp_dir("silent-http");
    let (db, _) = store(&dir);
    let port = free_port();
    // The header timeout (60 s) is far above the bound: only the idle timeout can close these.
    let _lb = start_leaderboard(
        &dir,
        "leaderboard",
        &db,
        port,
        &[
            "--header-timeout-s",
            "60",
            "--idle-timeout-s",
            "1",
            "--keepalive-s",
            "0.5",
        ],
    );
    let mut silent = connect(port);
    let mut partial = connect(port);
    partial.write_all(b"GET /subm").expect("send");
    for (what, s) in [
        ("a silent connection", &mut silent),
        ("a partial request line", &mut partial),
    ] {
        assert!(
            closed_within(s, CLOSED_BY, b"").is_some(),
            "{what} is still open after {CLOSED_BY:?}"
        );
    }
    assert_eq!(http_get(port, "/").0, 200);
}

#[test]
fn the_leaderboard_closes_connections_beyond_its_limit_and_answers_again_once_they_go() {
    let dir = temp_dir("conn-limit-http");
    let (db, _) = store(&dir);
    let port = free_port();
    let mut lb = start_leaderboard(
        &dir,
        "leaderboard",
        &db,
        port,
        &[
            "--header-timeout-s",
            "60",
            "--idle-timeout-s",
            "120",
            "--max-connections",
            "3",
        ],
    );
    // wait_port's probe may still hold a slot for a moment.
    get_ok_within(port, Duration::from_secs(10));
    let mut held: Vec<TcpStream> = (0..3).map(|_| connect(port)).collect();
    std::thread::sleep(Duration::from_millis(500));
    let fds = open_fds(lb.child.id());
    // One more is closed at once, and so are 200 more: the server keeps no descriptor for them.
    for i in 0..201 {
        let mut extra = connect(port);
        assert!(
            closed_within(&mut extra, CLOSED_BY, b"").is_some(),
            "connection {} beyond the limit is still open after {CLOSED_BY:?}",
            i + 4
        );
    }
    let after = open_fds(lb.child.id());
    assert!(
        after <= fds + 2,
        "the leaderboard's open descriptors grew from {fds} to {after} under refused connections"
    );
    for (i, s) in held.iter_mut().enumerate() {
        assert!(still_open(s), "held connection {i} was closed");
    }
    drop(held);
    get_ok_within(port, CLOSED_BY);
    assert!(
        lb.child.try_wait().expect("wait").is_none(),
        "{}",
        lb.output()
    );
}

/// Starts `vb coordinator` with `limits`.
fn coordinator(dir: &Path, db: &str, port: u16, limits: &[&str]) -> Proc {
    start_coordinator_with(dir, "coordinator", db, port, limits)
}

/// An HTTP/2 connection (answering pings while its driver runs) that sent one request and got an answer.
async fn h2_client(
    port: u16,
    path: &str,
) -> (
    h2::client::SendRequest<bytes::Bytes>,
    tokio::task::JoinHandle<()>,
) {
    let tcp = tokio::net::TcpStream::connect(("127.0.0.1", port))
        .await
        .expect("connect");
    let (send, conn) = h2::client::handshake(tcp).await.expect("h2 handshake");
    let driver = tokio::spawn(async move {
        let _ = conn.await;
    });
    let send = h2_request(send, port, path).await.expect("an answer");
    (send, driver)
}

/// Sends an (empty) gRPC request on `send` and waits for the answer's headers.
async fn h2_request(
    send: h2::client::SendRequest<bytes::Bytes>,
    port: u16,
    path: &str,
) -> Result<h2::client::SendRequest<bytes::Bytes>, h2::Error> {
    let mut send = send.ready().await?;
    let req = http::Request::builder()
        .method("POST")
        .uri(format!("http://127.0.0.1:{port}{path}"))
        .header("content-type", "application/grpc")
        .header("te", "trailers")
        .body(())
        .expect("request");
    let (answer, _) = send.send_request(req, true)?;
    answer.await?;
    Ok(send)
}

/// HEADERS (stream 1, END_STREAM, END_HEADERS) of a POST to `path`, literal HPACK without Huffman.
fn headers_frame(path: &str) -> Vec<u8> {
    let mut block = vec![0x83, 0x86]; // :method POST, :scheme http (static table)
    block.extend([0x04, path.len() as u8]); // :path, literal without indexing
    block.extend(path.as_bytes());
    block.extend([0x01, 1, b'a']); // :authority a
    let mut f = vec![0, 0, block.len() as u8, 1, 0x05, 0, 0, 0, 1];
    f.extend(block);
    f
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
        s.state == "done"
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

#[test]
fn vb_serve_applies_its_limits_to_both_ports() {
    let dir = temp_dir("serve-limits");
    let grpc = free_port();
    let http = free_port();
    let grpc_addr = format!("127.0.0.1:{grpc}");
    let http_addr = format!("127.0.0.1:{http}");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let _serve = Proc::start(
        "serve",
        &dir,
        &vb(),
        &[
            "serve",
            "--db",
            &db,
            "--grpc",
            &grpc_addr,
            "--http",
            &http_addr,
            "--slots",
            "1",
            "--header-timeout-s",
            "1",
            "--idle-timeout-s",
            "60",
        ],
    );
    wait_port(grpc, Duration::from_secs(60));
    wait_port(http, Duration::from_secs(60));
    let mut slow_http = connect(http);
    slow_http
        .write_all(b"GET / HTTP/1.1\r\nHost: localhost\r\n")
        .expect("send");
    let mut silent_grpc = connect(grpc);
    assert!(
        closed_within(
            &mut slow_http,
            CLOSED_BY,
            b"X-Slow: aaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaaa"
        )
        .is_some(),
        "vb serve's leaderboard keeps a slow-header connection past {CLOSED_BY:?}"
    );
    assert!(
        closed_within(&mut silent_grpc, CLOSED_BY, b"").is_some(),
        "vb serve's gRPC port keeps a silent connection past {CLOSED_BY:?}"
    );
    assert_eq!(http_get(http, "/").0, 200);
}

#[test]
fn limits_that_cannot_work_are_refused_with_the_flag_named() {
    for (args, says) in [
        (&["--header-timeout-s", "0"][..], "header timeout"),
        (&["--idle-timeout-s", "nan"][..], "idle timeout"),
        (&["--max-connections", "0"][..], "max connections"),
        (
            &["--keepalive-s", "200", "--idle-timeout-s", "100"][..],
            "keepalive interval",
        ),
    ] {
        let mut full = vec!["leaderboard", "--db", "sqlite:///nonexistent/vb.db"];
        full.extend_from_slice(args);
        let out = std::process::Command::new(vb())
            .args(&full)
            .output()
            .expect("vb");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} was accepted");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}
