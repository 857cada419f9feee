//! Raw clients of the slow-client tests: TCP connections that stall, trickle or answer nothing, and HTTP/2 clients
//! that answer pings.

use integration::create_token;
use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::time::{Duration, Instant};

/// The flags of issue 58's attack tests: a small limit and share, heads allowed to take 30 s.
pub const SHARE_LIMITS: [&str; 6] = [
    "--header-timeout-s",
    "30",
    "--max-connections",
    "40",
    "--max-connections-per-peer",
    "10",
];

/// The bound within which a connection past a 1 s timeout must have been closed.
pub const CLOSED_BY: Duration = Duration::from_secs(10);
/// The HTTP/2 client preface.
pub const PREFACE: &[u8] = b"PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n";
/// An empty SETTINGS frame.
pub const SETTINGS: &[u8] = &[0, 0, 0, 4, 0, 0, 0, 0, 0];

/// A connection whose reads give up after 100 ms (so a test can write between them).
pub fn connect(port: u16) -> TcpStream {
    let s = TcpStream::connect(("127.0.0.1", port)).expect("connect");
    s.set_read_timeout(Some(Duration::from_millis(100))).ok();
    s
}

/// A connection from loopback address `127.0.0.{from}` (every 127/8 address is this machine's), reads giving up
/// after 100 ms.
pub fn connect_from(from: u8, port: u16) -> std::io::Result<TcpStream> {
    use socket2::{Domain, Socket, Type};
    let s = Socket::new(Domain::IPV4, Type::STREAM, None)?;
    s.bind(&std::net::SocketAddr::from(([127, 0, 0, from], 0)).into())?;
    s.connect_timeout(
        &std::net::SocketAddr::from(([127, 0, 0, 1], port)).into(),
        Duration::from_secs(5),
    )?;
    let s: TcpStream = s.into();
    s.set_read_timeout(Some(Duration::from_millis(100))).ok();
    Ok(s)
}

/// GET / from `127.0.0.{from}` on a fresh connection: its status, or `None` if the server closed it unanswered.
pub fn get_from(from: u8, port: u16) -> Option<u16> {
    let mut s = connect_from(from, port).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(10))).ok();
    s.write_all(b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
        .ok()?;
    let mut head = [0u8; 12];
    s.read_exact(&mut head).ok()?;
    std::str::from_utf8(&head[9..12]).ok()?.parse().ok()
}

/// Whether the server has not closed `s` (what it sent is read and dropped).
fn not_closed(s: &mut TcpStream) -> bool {
    let mut buf = [0u8; 4096];
    s.set_nonblocking(true).ok();
    let open = loop {
        match s.read(&mut buf) {
            Ok(0) => break false,
            Ok(_) => {}
            Err(e) => break e.kind() == ErrorKind::WouldBlock,
        }
    };
    s.set_nonblocking(false).ok();
    open
}

/// An attacker at `127.0.0.{from}` for `for_`: keeps up to `hold` connections open, each sending `partial` (a
/// request head it never finishes), reopening each one the server closes, at most 100 new connections a second.
/// Returns how many connections it opened.
pub fn hold_partial_heads(
    from: u8,
    port: u16,
    hold: usize,
    partial: &[u8],
    for_: Duration,
) -> usize {
    let t0 = Instant::now();
    let mut open: Vec<TcpStream> = Vec::new();
    let mut opened = 0;
    while t0.elapsed() < for_ {
        // Drop the ones the server closed.
        open.retain_mut(not_closed);
        let mut this_round = 0;
        while open.len() < hold && this_round < 10 {
            if let Ok(mut s) = connect_from(from, port) {
                let _ = s.write_all(partial);
                open.push(s);
                opened += 1;
            }
            this_round += 1;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    opened
}

/// Reads (discarding what the server sends) and, every 200 ms, writes the next byte of `trickle`, until the server
/// closes the connection; how long that took, or `None` if it was still open after `limit`.
pub fn closed_within(s: &mut TcpStream, limit: Duration, trickle: &[u8]) -> Option<Duration> {
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
pub fn still_open(s: &mut TcpStream) -> bool {
    let mut buf = [0u8; 1];
    s.set_nonblocking(true).ok();
    let open = matches!(s.read(&mut buf), Err(e) if e.kind() == ErrorKind::WouldBlock);
    s.set_nonblocking(false).ok();
    open
}

pub fn open_fds(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd")).map_or(0, |d| d.count())
}

/// A store with one user token (which also creates the store).
pub fn store(dir: &Path) -> (String, String) {
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    (db, token)
}

/// The status of GET / on a fresh connection, or `None` if the server closed it without an answer.
pub fn try_get(port: u16) -> Option<u16> {
    let mut s = TcpStream::connect(("127.0.0.1", port)).ok()?;
    s.set_read_timeout(Some(Duration::from_secs(30))).ok();
    s.write_all(b"GET / HTTP/1.1\r\nHost: localhost\r\nConnection: close\r\n\r\n")
        .ok()?;
    let mut head = [0u8; 12];
    s.read_exact(&mut head).ok()?;
    std::str::from_utf8(&head[9..12]).ok()?.parse().ok()
}

/// A kept-alive HTTP/1.1 connection that the server answered, so it holds one of the server's slots, with its
/// answer read to the end. A connection the server closed instead (the slot a just-closed probe held had not been
/// given back yet) is replaced, until `limit`.
pub fn held_http(port: u16, limit: Duration) -> TcpStream {
    let t0 = Instant::now();
    loop {
        let mut s = connect(port);
        s.set_read_timeout(Some(Duration::from_secs(30))).ok();
        if s.write_all(b"GET /api/submissions HTTP/1.1\r\nHost: localhost\r\n\r\n")
            .is_ok()
            && read_answer(&mut s)
        {
            s.set_read_timeout(Some(Duration::from_millis(100))).ok();
            return s;
        }
        assert!(
            t0.elapsed() < limit,
            "no kept-alive connection answered within {limit:?}"
        );
        std::thread::sleep(Duration::from_millis(200));
    }
}

/// Reads one HTTP/1.1 answer with a Content-Length to its end; false if the connection closed first.
fn read_answer(s: &mut TcpStream) -> bool {
    let mut buf = Vec::new();
    let mut byte = [0u8; 1];
    while !buf.ends_with(b"\r\n\r\n") {
        match s.read(&mut byte) {
            Ok(1) => buf.push(byte[0]),
            _ => return false,
        }
    }
    let head = String::from_utf8_lossy(&buf).to_ascii_lowercase();
    let Some(len) = head
        .lines()
        .find_map(|l| l.strip_prefix("content-length:"))
        .and_then(|v| v.trim().parse::<usize>().ok())
    else {
        return false;
    };
    let mut body = vec![0u8; len];
    s.read_exact(&mut body).is_ok()
}

/// GET / until it answers 200 (the server may still be closing the connections a test let go).
pub fn get_ok_within(port: u16, limit: Duration) {
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

/// An HTTP/2 connection (answering pings while its driver runs) that sent one request and got an answer.
pub async fn h2_client(
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

/// Whether one gRPC request from a fresh HTTP/2 connection at `127.0.0.{from}` is answered (with any status).
pub async fn h2_answered_from(from: u8, port: u16, path: &str) -> bool {
    let Ok(std) = connect_from(from, port) else {
        return false;
    };
    if std.set_nonblocking(true).is_err() {
        return false;
    }
    let Ok(tcp) = tokio::net::TcpStream::from_std(std) else {
        return false;
    };
    let go = async {
        let (send, conn) = h2::client::handshake(tcp).await.ok()?;
        let driver = tokio::spawn(async move {
            let _ = conn.await;
        });
        let ok = h2_request(send, port, path).await.is_ok();
        driver.abort();
        Some(ok)
    };
    matches!(
        tokio::time::timeout(Duration::from_secs(10), go).await,
        Ok(Some(true))
    )
}

/// Sends an (empty) gRPC request on `send` and waits for the answer's headers.
pub async fn h2_request(
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
pub fn headers_frame(path: &str) -> Vec<u8> {
    let mut block = vec![0x83, 0x86]; // :method POST, :scheme http (static table)
    block.extend([0x04, path.len() as u8]); // :path, literal without indexing
    block.extend(path.as_bytes());
    block.extend([0x01, 1, b'a']); // :authority a
    let mut f = vec![0, 0, block.len() as u8, 1, 0x05, 0, 0, 0, 1];
    f.extend(block);
    f
}
