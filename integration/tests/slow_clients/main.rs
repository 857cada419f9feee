//! Slow and silent clients against every network server, as real `vb` processes with small limits set by flags
//! (issue 35, point 5): the leaderboard (`vb leaderboard`, `vb serve --http`), the coordinator's gRPC port (`vb
//! coordinator`, `vb serve --grpc`) and the `Sim` API (`vb worker --sim`).
//!
//! Nothing here measures speed: a connection must be closed within a generous bound (10 s for a 1 s timeout) that
//! is far below the limits that must not be what closed it.
//!
//! `clients` holds the raw clients; `leaderboard` the leaderboard's tests, `grpc` the coordinator's and the Sim API's.

mod clients;
mod grpc;
mod leaderboard;

use clients::*;
use integration::*;
use std::io::Write;
use std::time::Duration;

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
