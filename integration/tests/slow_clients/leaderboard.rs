//! The leaderboard (`vb leaderboard`): slow headers, silent connections, the connection limit.

use crate::clients::*;
use integration::*;
use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::Duration;

fn start_leaderboard(dir: &Path, name: &str, db: &str, port: u16, limits: &[&str]) -> Proc {
    let listen = format!("127.0.0.1:{port}");
    let mut args = vec!["leaderboard", "--db", db, "--listen", &listen];
    args.extend_from_slice(limits);
    let p = Proc::start(name, dir, &vb(), &args);
    wait_port(port, Duration::from_secs(30));
    p
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
    // wait_port's and get_ok_within's probes may still hold a slot for a moment: each held connection is one the
    // server answered, so all three slots are theirs.
    get_ok_within(port, Duration::from_secs(10));
    let mut held: Vec<TcpStream> = (0..3).map(|_| held_http(port, CLOSED_BY)).collect();
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

/// Issue 58, point 1: one client that holds every connection it can with request heads it never finishes (and
/// reopens each one closed) gets its peer address's share and no more, and head-less connections from many
/// addresses make way for new clients: fresh requests from another address are all answered during both attacks.
#[test]
fn one_client_cannot_lock_others_out_and_headless_floods_make_way() {
    let dir = temp_dir("conn-share-http");
    let (db, _) = store(&dir);
    let port = free_port();
    let mut lb = start_leaderboard(&dir, "leaderboard", &db, port, &SHARE_LIMITS);
    get_ok_within(port, Duration::from_secs(10));
    let partial = b"GET / HTTP/1.1\r\nHost: localhost\r\n";
    // One attacker at 127.0.0.1 trying to hold 60 connections.
    let attack = std::thread::spawn(move || {
        hold_partial_heads(1, port, 60, partial, Duration::from_secs(6))
    });
    std::thread::sleep(Duration::from_secs(1));
    let answered = (0..20)
        .filter(|_| {
            std::thread::sleep(Duration::from_millis(100));
            get_from(2, port) == Some(200)
        })
        .count();
    let opened = attack.join().expect("attacker");
    assert!(
        opened >= 10,
        "the attacker opened only {opened} connections"
    );
    assert_eq!(
        answered,
        20,
        "{} of 20 fresh requests went unanswered under one client's flood",
        20 - answered
    );
    // Eight attackers at 127.0.0.3-10 holding their 10 each: 80 head-less connections for 40 places.
    let attackers: Vec<_> = (3..=10u8)
        .map(|ip| {
            std::thread::spawn(move || {
                hold_partial_heads(ip, port, 10, partial, Duration::from_secs(6))
            })
        })
        .collect();
    std::thread::sleep(Duration::from_secs(1));
    let answered = (0..20)
        .filter(|_| {
            std::thread::sleep(Duration::from_millis(100));
            get_from(2, port) == Some(200)
        })
        .count();
    for a in attackers {
        a.join().expect("attacker");
    }
    assert_eq!(
        answered,
        20,
        "{} of 20 fresh requests went unanswered under a flood from many addresses",
        20 - answered
    );
    assert!(
        lb.child.try_wait().expect("wait").is_none(),
        "{}",
        lb.output()
    );
}
