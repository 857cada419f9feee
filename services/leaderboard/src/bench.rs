//! `vb bench leaderboard`: seeds a throw-away store with finished submissions through the store's own API (as the
//! coordinator would fill it), serves the leaderboard on loopback and measures request latency at a fixed request
//! rate. The load is open-loop: requests leave on a fixed schedule whether or not earlier ones were answered, and
//! each latency counts from its scheduled departure, so a slow server cannot hide its queueing.

use crate::Leaderboard;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tasks::TaskSet;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use vb_store::{EpisodeResultIn, NewEpisode, NewSubmission, Store, StoreError};

/// Seeds `submissions` finished submissions of `episodes` episodes each (tasks of `set`, outcomes mixed, a
/// trajectory of `trajectory_rows` rows and a short log per episode), each with its stored aggregates. Returns
/// their ids.
pub async fn seed(
    store: &Store,
    set: &TaskSet,
    submissions: usize,
    episodes: usize,
    trajectory_rows: usize,
) -> Result<Vec<String>, StoreError> {
    let tasks: Vec<NewEpisode> = set
        .world_ids()
        .iter()
        .flat_map(|&w| (0..10u32).map(move |t| (w, t)))
        .cycle()
        .take(episodes)
        .enumerate()
        .map(|(i, (w, t))| {
            let meta = set.world_meta(w).ok();
            NewEpisode {
                // Unique even when more episodes than tasks are asked for.
                task_id: format!("w{w:03}-t{t}-{}", i / (set.world_ids().len() * 10).max(1)),
                world_id: w,
                task_index: t,
                level: meta
                    .as_ref()
                    .map_or("low".into(), |m| m.level.as_str().into()),
                semantics: meta
                    .as_ref()
                    .map_or("rigid".into(), |m| m.semantics.as_str().into()),
                density: meta
                    .as_ref()
                    .map_or("sparse".into(), |m| m.density.as_str().into()),
            }
        })
        .collect();
    let mut trajectory = String::from("time,x,y,z,roll,pitch,yaw,speed,throttle,steering,brake\n");
    for k in 0..trajectory_rows {
        let t = k as f64 * 0.1;
        trajectory += &format!(
            "{t:.2},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.3},0.8,{:.3},0\n",
            10.0 + 2.0 * t,
            20.0 + 0.5 * t,
            1.0 + (t * 0.3).sin(),
            0.05 * (t * 0.7).sin(),
            0.04 * (t * 0.5).cos(),
            0.3,
            3.0 + (t * 0.2).sin(),
            0.1 * (t * 0.9).sin()
        );
    }
    let metrics = serde_json::to_string(&sim_core::episode::EpisodeMetrics {
        time: 42.0,
        path_length: 80.0,
        ..Default::default()
    })
    .unwrap_or_default();
    let worker = store
        .register_worker("bench", 256, "bench", "bench-token", 0.0)
        .await?;
    let outcomes = [
        "success", "stuck", "success", "rollover", "timeout", "success",
    ];
    let mut ids = Vec::new();
    for s in 0..submissions {
        let sub = NewSubmission {
            name: format!("bench-{s:03}"),
            owner: "bench".into(),
            owner_token: "bench".into(),
            planner_kind: "builtin".into(),
            planner_spec: "pid".into(),
            planner_identity: "builtin:pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: s as u64,
            step_deadline_s: 1.0,
            task_set_version: set.version().into(),
            sim_version: "bench".into(),
        };
        let t = 1.0 + s as f64;
        let id = store.create_submission(&sub, &tasks, t).await?;
        let mut k = s;
        loop {
            let leases = store.lease(&worker, 256, 600.0, true, t).await?;
            if leases.is_empty() {
                break;
            }
            for l in leases {
                let outcome = outcomes[k % outcomes.len()];
                k += 1;
                let r = EpisodeResultIn {
                    lease_id: l.lease_id,
                    submission_id: l.submission.id,
                    task_id: l.task_id,
                    outcome: outcome.into(),
                    reason: outcome.into(),
                    detail: String::new(),
                    metrics_json: metrics.clone(),
                    trajectory_csv: trajectory.clone(),
                    planner_log: "planner: ready\n".into(),
                    sim_version: "bench".into(),
                    planner_identity: "builtin:pid".into(),
                    wall_time_s: 0.05,
                };
                store.report(&worker, &r, t).await?;
            }
        }
        store.refresh_summary(&id, Some(set), t + 0.5).await?;
        ids.push(id);
    }
    Ok(ids)
}

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
    tokio::spawn(crate::serve(lb, listener));
    Ok(addr)
}
