//! `vb serve` (coordinator, leaderboard and a worker pool in one process) and `vb coordinator`.

use super::args::{CoordinatorArgs, ServeArgs};
use super::common::{
    bind, catalog, hide_from_planners, open_store, planner_user, runtime, served_tasks,
    sim_service, sqlite_files, start_coordinator, without_credentials, StopSignal,
};
use anyhow::bail;
use std::time::Duration;
use vb_coordinator::CoordinatorConfig;
use vb_leaderboard::Leaderboard;

/// `vb serve --evaluate PLANNER`: submits a built-in planner through the gRPC API and watches it to the end.
async fn evaluate_builtin(
    grpc_addr: std::net::SocketAddr,
    http_addr: std::net::SocketAddr,
    token: &str,
    planner: &str,
    tasks: &str,
) -> anyhow::Result<()> {
    let mut client = vb_submit::connect(&format!("http://{grpc_addr}"), token, None).await?;
    let task_ids = if tasks.trim() == "all" {
        Vec::new()
    } else {
        tasks.split(',').map(|s| s.trim().to_string()).collect()
    };
    let t0 = std::time::Instant::now();
    let r = vb_submit::submit(
        &mut client,
        vb_submit::SubmitRequest {
            name: format!("{planner} (builtin)"),
            planner: Some(vb_submit::PlannerRef {
                kind: Some(vb_proto::v1::planner_ref::Kind::Builtin(
                    planner.to_string(),
                )),
            }),
            task_ids,
            ..Default::default()
        },
    )
    .await?;
    eprintln!(
        "submitted {} ({} episodes) through the gRPC API",
        r.submission_id, r.episodes
    );
    let last = vb_submit::watch(&mut client, &r.submission_id, |s| {
        eprint!("\r{}   ", vb_submit::status_line(s))
    })
    .await?;
    eprintln!();
    println!("{}", vb_submit::status_line(&last));
    println!("wall time {:.1} s", t0.elapsed().as_secs_f64());
    println!(
        "leaderboard: http://{http_addr}/submissions/{}",
        r.submission_id
    );
    Ok(())
}

pub fn serve(a: ServeArgs) -> anyhow::Result<()> {
    let limits = a.net.limits()?;
    runtime()?.block_on(async move {
        let mut signal = StopSignal::new()?;
        let store = open_store(&a.db).await?;
        hide_from_planners(&sqlite_files(&a.db));
        let grpc = bind(a.grpc, "coordinator gRPC API").await?;
        let http = bind(a.http, "leaderboard").await?;
        let grpc_addr = grpc.local_addr()?;
        let http_addr = http.local_addr()?;
        let sim = sim_service(&a.task_dir, &a.sim_access)?;
        let mut ccfg = CoordinatorConfig::new(catalog(&a.task_dir)?);
        ccfg.allow_exec = !a.no_exec;
        let coord = start_coordinator(store.clone(), ccfg, grpc, Some(sim), None, &limits).await?;
        let served = served_tasks(tasks::TaskSet::load(&a.task_dir)?);
        let lb = Leaderboard::new(store.reader(), sim_core::SIM_VERSION, Some(served));
        tokio::spawn(async move {
            if let Err(e) = vb_leaderboard::serve_with(lb, http, &limits).await {
                tracing::error!(error = %e, "leaderboard stopped");
            }
        });
        let (stop, shutdown) = tokio::sync::watch::channel(false);
        let worker_token = coord
            .store()
            .create_token("vb-serve-worker", vb_store::TokenRole::Worker, vb_coordinator::now())
            .await?;
        let wcfg = vb_worker::WorkerConfig {
            tls_ca: None,
            coordinator: format!("http://{grpc_addr}"),
            name: "serve-local".into(),
            slots: a.slots.max(1),
            task_dir: a.task_dir.clone(),
            planner_startup_s: 30.0,
            allow_exec: !a.no_exec,
            token: worker_token,
            planner_user: planner_user(a.planner_user.as_deref())?,
            // vb serve stops as a whole: its workers hand their episodes back at once.
            drain: Duration::ZERO,
        };
        let workers = tokio::spawn(async move {
            if let Err(e) = vb_worker::run_worker(wcfg, shutdown).await {
                tracing::error!(error = %e, "worker stopped");
            }
        });
        let token = coord
            .store()
            .create_token("vb-serve", vb_store::TokenRole::User, vb_coordinator::now())
            .await?;
        eprintln!("coordinator and Sim gRPC APIs on {grpc_addr}, leaderboard on http://{http_addr}/, {} local worker slots", a.slots);
        eprintln!("submit your own planner with: VB_COORDINATOR=http://{grpc_addr} VB_TOKEN={token} vb-submit endpoint URL --name NAME");
        // A signal during the evaluation stops it: the workers hand its running episodes back below and the
        // submission stays in the store.
        let stopped = match &a.evaluate {
            Some(planner) => tokio::select! {
                r = evaluate_builtin(grpc_addr, http_addr, &token, planner, &a.tasks) => {
                    r?;
                    if a.exit_when_done {
                        return Ok(());
                    }
                    false
                }
                _ = signal.recv() => true,
            },
            None => false,
        };
        if !stopped {
            println!("leaderboard: http://{http_addr}/  (Ctrl-C or SIGTERM to stop)");
            signal.recv().await;
        }
        // The workers hand their running episodes back while the coordinator still listens.
        let _ = stop.send(true);
        let _ = tokio::time::timeout(Duration::from_secs(5), workers).await;
        Ok(())
    })
}

pub fn coordinator(a: CoordinatorArgs) -> anyhow::Result<()> {
    if !(a.lease_s > 0.0 && a.heartbeat_s > 0.0 && a.heartbeat_s < a.lease_s) {
        bail!(
            "need 0 < --heartbeat-s < --lease-s (got {} and {})",
            a.heartbeat_s,
            a.lease_s
        );
    }
    let limits = a.net.limits()?;
    runtime()?.block_on(async move {
        let mut signal = StopSignal::new()?;
        let store = open_store(&a.db).await?;
        let listener = bind(a.listen, "coordinator gRPC API").await?;
        let mut cfg = CoordinatorConfig::new(catalog(&a.task_dir)?);
        cfg.lease_s = a.lease_s;
        cfg.heartbeat_s = a.heartbeat_s;
        cfg.allow_exec = !a.no_exec;
        cfg.max_dropped_leases = a.max_dropped_leases;
        cfg.drop_window_s = a.drop_window_s;
        cfg.max_handed_back_leases = a.max_handed_back_leases;
        tracing::info!(
            addr = %listener.local_addr()?,
            tls = a.tls_cert.is_some(),
            store = %without_credentials(&a.db),
            task_dir = %a.task_dir.display(),
            "coordinator listening"
        );
        let tls = match (&a.tls_cert, &a.tls_key) {
            (Some(cert), Some(key)) => Some(vb_coordinator::server_tls(cert, key)?),
            _ => None,
        };
        start_coordinator(store, cfg, listener, None, tls, &limits).await?;
        signal.recv().await;
        Ok(())
    })
}
