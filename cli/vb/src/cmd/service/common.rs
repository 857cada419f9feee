//! What the service's subcommands share: the async runtime, the stop signal, the store, listening sockets, the
//! `Sim` API and starting the coordinator.

use anyhow::{bail, Context};
use std::net::SocketAddr;
use std::sync::Arc;
use tokio::net::TcpListener;
use vb_coordinator::{Coordinator, CoordinatorConfig};
use vb_store::Store;

/// The user named by `--planner-user`, if any.
pub(super) fn planner_user(
    name: Option<&str>,
) -> anyhow::Result<Option<vb_worker::sandbox::PlannerUser>> {
    name.map(vb_worker::sandbox::PlannerUser::lookup)
        .transpose()
        .map_err(anyhow::Error::msg)
}

/// Covers this process's secrets in the view of every exec planner it starts ([`vb_worker::sandbox::hidden`]):
/// `files` (the worker's token file, the store's SQLite files), and the user's own submission token.
pub(super) fn hide_from_planners(files: &[std::path::PathBuf]) {
    let mut all = files.to_vec();
    if let Some(home) = std::env::var_os("HOME") {
        all.push(std::path::Path::new(&home).join(".config/vertibench/token"));
    }
    vb_worker::sandbox::hidden::hide_from_planners(all);
}

/// The files of a `sqlite://PATH[?...]` store (its journal files too); none for another database.
pub(super) fn sqlite_files(url: &str) -> Vec<std::path::PathBuf> {
    let Some(rest) = url.strip_prefix("sqlite://") else {
        return Vec::new();
    };
    let path = rest.split('?').next().unwrap_or(rest);
    ["", "-wal", "-shm", "-journal"]
        .iter()
        .map(|ext| std::path::PathBuf::from(format!("{path}{ext}")))
        .collect()
}

/// A database URL for a log line: the password (and user) of `postgres://user:password@host/db` left out.
pub(super) fn without_credentials(url: &str) -> String {
    match (url.split_once("://"), url.rsplit_once('@')) {
        (Some((scheme, _)), Some((_, host))) => format!("{scheme}://***@{host}"),
        _ => url.to_string(),
    }
}

/// Ctrl-C (SIGINT) and SIGTERM, caught from the moment this is made: made first thing, so a signal that arrives while
/// a service starts stops it cleanly at its next wait instead of killing it half-started (the default action).
pub(super) struct StopSignal {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
}

impl StopSignal {
    pub(super) fn new() -> anyhow::Result<StopSignal> {
        use tokio::signal::unix::{signal, SignalKind};
        Ok(StopSignal {
            term: signal(SignalKind::terminate())?,
            int: signal(SignalKind::interrupt())?,
        })
    }

    pub(super) async fn recv(&mut self) {
        tokio::select! {
            _ = self.term.recv() => {}
            _ = self.int.recv() => {}
        }
    }
}

pub(super) fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("starting the async runtime")
}

/// Creates the directory of a SQLite database file.
fn prepare_db(url: &str) -> anyhow::Result<()> {
    if let Some(path) = url.strip_prefix("sqlite://") {
        let path = path.split('?').next().unwrap_or(path);
        if let Some(dir) = std::path::Path::new(path).parent() {
            if !dir.as_os_str().is_empty() {
                std::fs::create_dir_all(dir)
                    .with_context(|| format!("creating {}", dir.display()))?;
            }
        }
    }
    Ok(())
}

pub(super) async fn open_store(url: &str) -> anyhow::Result<Store> {
    prepare_db(url)?;
    Store::open(url)
        .await
        .with_context(|| format!("opening the store at {url}"))
}

/// The store to administer: the one `--db` names, or the default `sqlite://out/vb.db`, which must already exist (run
/// from another directory it would be a new, empty store, and its token one no service knows).
pub(super) async fn admin_store(db: Option<&str>) -> anyhow::Result<Store> {
    let Some(url) = db else {
        return open_existing_store(DEFAULT_DB).await;
    };
    open_store(url).await
}

const DEFAULT_DB: &str = "sqlite://out/vb.db";

async fn open_existing_store(url: &str) -> anyhow::Result<Store> {
    if let Some(path) = url.strip_prefix("sqlite://") {
        let path = path.split('?').next().unwrap_or(path);
        if !std::path::Path::new(path).exists() {
            bail!(
                "no store at {path} (in {}): run this where `vb serve` or `vb coordinator` runs, or pass --db \
                 with their store",
                std::env::current_dir().map_or("?".into(), |d| d.display().to_string())
            );
        }
    }
    open_store(url).await
}

pub(super) async fn bind(addr: SocketAddr, what: &str) -> anyhow::Result<TcpListener> {
    TcpListener::bind(addr)
        .await
        .with_context(|| format!("cannot listen on {addr} for the {what} (is another vb running? pick another with a flag)"))
}

/// The `Sim` API on the task set in `dir`.
pub(super) fn sim_service(
    dir: &std::path::Path,
    access: &super::args::SimAccessArgs,
) -> anyhow::Result<vb_worker::sim_service::SimService> {
    let access = access.access()?;
    let set = tasks::TaskSet::load(dir)
        .with_context(|| format!("loading the task set {}", dir.display()))?;
    if !access.needs_token() {
        tracing::info!(
            "the Sim API serves clients on this machine only (no --sim-token-file or VB_SIM_TOKEN)"
        );
    }
    Ok(vb_worker::sim_service::SimService::new(
        Arc::new(set),
        access,
    ))
}

/// Starts the coordinator's gRPC services on `listener` within `limits`, with the `Sim` API when `sim` is given.
pub(super) async fn start_coordinator(
    store: Store,
    cfg: CoordinatorConfig,
    listener: TcpListener,
    sim: Option<vb_worker::sim_service::SimService>,
    tls: Option<tonic::transport::ServerTlsConfig>,
    limits: &vb_net::Limits,
) -> anyhow::Result<Arc<Coordinator>> {
    let coord = Coordinator::new(store, cfg)?;
    tokio::spawn(coord.clone().run_lease_sweeper());
    tokio::spawn(coord.clone().run_summary_keeper());
    let mut grpc = vb_coordinator::grpc_router(&coord, tls, limits)?;
    if let Some(sim) = sim {
        grpc = grpc.add_service(sim.server());
    }
    let incoming = vb_net::grpc::incoming(listener, limits, "coordinator gRPC API");
    tokio::spawn(async move {
        if let Err(e) = grpc.serve_with_incoming(incoming).await {
            tracing::error!(error = %e, "coordinator gRPC server stopped");
        }
    });
    Ok(coord)
}

/// The benchmark the services serve: the task set at `task_dir` under this build's simulator, vehicles and
/// built-in planners (`eval::catalog`).
pub fn catalog(task_dir: &std::path::Path) -> anyhow::Result<Arc<contracts::Catalog>> {
    let set = tasks::TaskSet::load(task_dir)
        .with_context(|| format!("loading the task set at {}", task_dir.display()))?;
    Ok(Arc::new(eval::catalog(&set)))
}

/// The task set a leaderboard serves: its catalog, and its worlds drawn by `tasks`.
pub fn served_tasks(set: tasks::TaskSet) -> vb_leaderboard::ServedTasks {
    let catalog = Arc::new(eval::catalog(&set));
    let draw = move |id| {
        set.world_picture(id, vb_leaderboard::pages::MAP_PPM)
            .map_err(|e| e.to_string())
    };
    vb_leaderboard::ServedTasks {
        catalog,
        draw: Arc::new(draw),
    }
}
