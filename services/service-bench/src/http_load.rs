//! `vb bench leaderboard`: serves the leaderboard on loopback over a store seeded by [`crate::seed`] and measures
//! request latency at a fixed request rate. The load is open-loop: requests leave on a fixed schedule whether or not earlier ones were answered, and
//! each latency counts from its scheduled departure, so a slow server cannot hide its queueing.

use std::sync::Arc;
use std::time::{Duration, Instant};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use vb_leaderboard::Leaderboard;

/// Latencies of one path under load.
#[derive(Clone, Debug)]
pub struct LoadResult {
    pub path: String,
    pub rate: f64,
    pub requests: usize,
    /// Requests answered with a status other than 200, or not at all.
    pub failed: usize,
    pub p50_ms: f64,
    pub p99_ms: f64,
    pub max_ms: f64,
    pub bytes: usize,
}

/// One GET over a fresh connection: (status 200?, body bytes).
async fn get(addr: std::net::SocketAddr, path: &str) -> std::io::Result<(bool, usize)> {
    let mut s = tokio::net::TcpStream::connect(addr).await?;
    s.write_all(
        format!("GET {path} HTTP/1.1\r\nHost: bench\r\nConnection: close\r\n\r\n").as_bytes(),
    )
    .await?;
    let mut buf = Vec::new();
    s.read_to_end(&mut buf).await?;
    let ok = buf.starts_with(b"HTTP/1.1 200");
    Ok((ok, buf.len()))
}

/// Requests `path` at `rate` per second for `seconds`, open-loop.
pub async fn load(addr: std::net::SocketAddr, path: &str, rate: f64, seconds: f64) -> LoadResult {
    let n = (rate * seconds).round().max(1.0) as usize;
    let start = Instant::now() + Duration::from_millis(20);
    let mut handles = Vec::with_capacity(n);
    for i in 0..n {
        let due = start + Duration::from_secs_f64(i as f64 / rate);
        let path = path.to_string();
        handles.push(tokio::spawn(async move {
            tokio::time::sleep_until(due.into()).await;
            let r = tokio::time::timeout(Duration::from_secs(30), get(addr, &path)).await;
            let ms = due.elapsed().as_secs_f64() * 1e3;
            match r {
                Ok(Ok((ok, bytes))) => (ok, ms, bytes),
                _ => (false, ms, 0),
            }
        }));
    }
    let mut ms = Vec::with_capacity(n);
    let (mut failed, mut bytes) = (0, 0);
    for h in handles {
        let (ok, t, b) = h.await.unwrap_or((false, f64::NAN, 0));
        failed += usize::from(!ok);
        bytes = bytes.max(b);
        ms.push(t);
    }
    ms.sort_by(f64::total_cmp);
    let q = |p: f64| ms[((ms.len() - 1) as f64 * p).round() as usize];
    LoadResult {
        path: path.to_string(),
        rate,
        requests: n,
        failed,
        p50_ms: q(0.5),
        p99_ms: q(0.99),
        max_ms: ms.last().copied().unwrap_or(f64::NAN),
        bytes,
    }
}

/// Serves `lb` on a loopback port; returns the address (the server runs until the runtime ends).
pub async fn serve_loopback(lb: Arc<Leaderboard>) -> std::io::Result<std::net::SocketAddr> {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    tokio::spawn(vb_leaderboard::serve(lb, listener));
    Ok(addr)
}
