//! `vb worker`: runs episodes leased from a coordinator, optionally serving the `Sim` API.

use super::args::WorkerArgs;
use super::common::{bind, hide_from_planners, planner_user, runtime, sim_service, StopSignal};
use anyhow::{bail, Context};
use std::time::Duration;

/// The worker token: from `--token-file` or `VB_WORKER_TOKEN`, never from the command line.
fn worker_token(a: &WorkerArgs) -> anyhow::Result<String> {
    if a.token.is_some() {
        bail!(
            "--token puts the worker token on the command line, where every process on this machine can read it \
             (/proc/PID/cmdline): set VB_WORKER_TOKEN or pass --token-file FILE instead"
        );
    }
    let token = match &a.token_file {
        Some(path) => std::fs::read_to_string(path)
            .with_context(|| format!("reading the worker token from {}", path.display()))?,
        None => std::env::var("VB_WORKER_TOKEN").unwrap_or_default(),
    };
    let token = token.trim().to_string();
    if token.is_empty() {
        bail!(
            "no worker token: set VB_WORKER_TOKEN or pass --token-file FILE (create one with `vb admin token \
             create --name NAME --role worker --db STORE`)"
        );
    }
    Ok(token)
}

pub fn worker(a: WorkerArgs) -> anyhow::Result<()> {
    let token = worker_token(&a)?;
    hide_from_planners(a.token_file.as_slice());
    let limits = a.net.limits()?;
    runtime()?.block_on(async move {
        let (stop, shutdown) = tokio::sync::watch::channel(false);
        let mut signal = StopSignal::new()?;
        tokio::spawn(async move {
            signal.recv().await;
            tracing::info!("stopping (its planners are stopped with it)");
            let _ = stop.send(true);
        });
        let cfg = vb_worker::WorkerConfig {
            tls_ca: a.tls_ca.clone(),
            coordinator: a.coordinator.clone(),
            name: a.name.clone().unwrap_or_else(|| {
                let host = std::env::var("HOSTNAME").unwrap_or_else(|_| "worker".into());
                format!("{host}-{}", std::process::id())
            }),
            slots: a.slots,
            task_dir: a.task_dir.clone(),
            planner_startup_s: a.planner_startup_s,
            allow_exec: !a.no_exec,
            token,
            planner_user: planner_user(a.planner_user.as_deref())?,
            drain: Duration::from_secs_f64(a.drain_s.clamp(0.0, 3600.0)),
        };
        if let Some(addr) = a.sim {
            let sim = sim_service(&a.task_dir, &a.sim_access)?;
            let listener = bind(addr, "Sim API").await?;
            tracing::info!(addr = %listener.local_addr()?, "Sim API listening");
            tokio::spawn(async move {
                if let Err(e) = sim.serve(listener, &limits).await {
                    tracing::error!(error = %e, "Sim API stopped");
                }
            });
        }
        vb_worker::run_worker(cfg, shutdown).await?;
        Ok(())
    })
}
