//! `vb serve`, `vb coordinator`, `vb worker`, `vb leaderboard`, `vb admin`: the evaluation service.

use anyhow::{bail, Context};
use clap::{Args, Subcommand};
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;
use tokio::net::TcpListener;
use vb_coordinator::{Coordinator, CoordinatorConfig};
use vb_leaderboard::Leaderboard;
use vb_store::Store;

use super::net_args::NetArgs;

fn default_slots() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get())
}

#[derive(Args)]
pub struct ServeArgs {
    /// Results store (SQLite file or postgres:// URL).
    #[arg(long, default_value = "sqlite://out/vb.db")]
    db: String,
    /// gRPC address of the coordinator (submission and worker APIs, and the Sim API).
    #[arg(long, default_value = "127.0.0.1:50051")]
    grpc: SocketAddr,
    /// HTTP address of the leaderboard.
    #[arg(long, default_value = "127.0.0.1:8080")]
    http: SocketAddr,
    /// Episodes run at once by the in-process worker pool.
    #[arg(long, default_value_t = default_slots())]
    slots: usize,
    /// Task-set directory (default: the benchmark's committed set, tasks/data/v4).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::TaskSet::default_dir(), hide_default_value = true)]
    task_dir: PathBuf,
    /// Submit this built-in planner through the gRPC API and follow it to the end.
    #[arg(long)]
    evaluate: Option<String>,
    /// Tasks of that evaluation: `all`, or world ids and task ids.
    #[arg(long, default_value = "all")]
    tasks: String,
    /// Stop once the evaluation has finished instead of serving on.
    #[arg(long)]
    exit_when_done: bool,
    /// Refuse exec and image planners (untrusted code; exec planners run as this process's user): only endpoints
    /// and built-ins. Use it whenever strangers can submit.
    #[arg(long)]
    no_exec: bool,
    /// Run exec planners as this unprivileged user (needs root), so they cannot read the service's files.
    #[arg(long)]
    planner_user: Option<String>,
    #[command(flatten)]
    net: NetArgs,
}

#[derive(Args)]
pub struct CoordinatorArgs {
    /// Results store: a SQLite file (`sqlite://PATH`) or a PostgreSQL URL; the coordinator is its only writer.
    #[arg(long, default_value = "sqlite://out/vb.db")]
    db: String,
    /// gRPC address of the submission and worker APIs.
    #[arg(long, default_value = "127.0.0.1:50051")]
    listen: SocketAddr,
    /// Task-set directory (default: the benchmark's committed set, tasks/data/v4).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::TaskSet::default_dir(), hide_default_value = true)]
    task_dir: PathBuf,
    /// Lease length without a heartbeat, s: a dead worker's episodes are re-queued after this.
    #[arg(long, default_value_t = 30.0)]
    lease_s: f64,
    /// Heartbeat period asked of workers, s.
    #[arg(long, default_value_t = 5.0)]
    heartbeat_s: f64,
    /// Refuse exec and image planners (only endpoints and built-ins).
    #[arg(long)]
    no_exec: bool,
    /// A worker token whose workers drop this many leases (expired or released without a result) within
    /// --drop-window-s gets no new leases until the window has passed.
    #[arg(long, default_value_t = 32)]
    max_dropped_leases: u64,
    /// The window of --max-dropped-leases and --max-handed-back-leases, s.
    #[arg(long, default_value_t = 600.0)]
    drop_window_s: f64,
    /// A worker token whose workers hand back this many leases unrun (stopping workers do, and workers refusing a
    /// submission they cannot run, without using an attempt) within --drop-window-s gets no new leases until fewer remain in the window: a budget of its own,
    /// so draining workers are not throttled but a token leasing and handing back in a loop is.
    #[arg(long, default_value_t = 256)]
    max_handed_back_leases: u64,
    /// Serve gRPC over TLS with this certificate chain (PEM); clients then connect to https://.
    #[arg(long, requires = "tls_key")]
    tls_cert: Option<PathBuf>,
    /// The private key (PEM) of --tls-cert.
    #[arg(long, requires = "tls_cert")]
    tls_key: Option<PathBuf>,
    #[command(flatten)]
    net: NetArgs,
}

#[derive(Args)]
pub struct WorkerArgs {
    /// The coordinator's URL (https:// for TLS).
    #[arg(long, default_value = "http://127.0.0.1:50051")]
    coordinator: String,
    /// CA certificate (PEM) to verify an https:// coordinator against (default: the public web PKI roots).
    #[arg(long, env = "VB_TLS_CA")]
    tls_ca: Option<PathBuf>,
    /// Episodes run at once (default: the number of cores).
    #[arg(long, default_value_t = default_slots())]
    slots: usize,
    /// Name shown in the coordinator's logs.
    #[arg(long)]
    name: Option<String>,
    /// Task-set directory (default: the benchmark's committed set, tasks/data/v4).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::TaskSet::default_dir(), hide_default_value = true)]
    task_dir: PathBuf,
    /// How long a planner process may take to start serving, s.
    #[arg(long, default_value_t = 30.0)]
    planner_startup_s: f64,
    /// Also serve the client-driven `Sim` gRPC API on this address (e.g. 127.0.0.1:50052).
    #[arg(long)]
    sim: Option<SocketAddr>,
    /// Do not run exec or image planners (they are untrusted code; exec planners run as this worker's user).
    #[arg(long)]
    no_exec: bool,
    /// Refused: a token on the command line is readable by every process on the machine (`/proc/PID/cmdline`).
    /// Give the worker token (`vb admin token create --role worker`) in the environment variable VB_WORKER_TOKEN or
    /// in a file (--token-file).
    #[arg(long, hide = true)]
    token: Option<String>,
    /// File holding the worker token (`vb admin token create --role worker`; one line). Without it the token is read
    /// from the environment variable VB_WORKER_TOKEN. Never on the command line.
    #[arg(long)]
    token_file: Option<PathBuf>,
    /// Run exec planners as this unprivileged user (needs root), so they cannot read the worker's files.
    #[arg(long)]
    planner_user: Option<String>,
    /// On SIGTERM or Ctrl-C, seconds running episodes get to finish before the rest are stopped and handed back to
    /// the queue (keep it below the time the process manager waits before SIGKILL).
    #[arg(long, default_value_t = 20.0)]
    drain_s: f64,
    #[command(flatten)]
    net: NetArgs,
}

#[derive(Args)]
pub struct LeaderboardArgs {
    /// Results store to read (the coordinator's).
    #[arg(long, default_value = "sqlite://out/vb.db")]
    db: String,
    /// HTTP address of the pages and the JSON API.
    #[arg(long, default_value = "127.0.0.1:8080")]
    listen: SocketAddr,
    /// Task-set directory (default: the benchmark's committed set, tasks/data/v4).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::TaskSet::default_dir(), hide_default_value = true)]
    task_dir: PathBuf,
    #[command(flatten)]
    net: NetArgs,
}

#[derive(Subcommand)]
pub enum AdminCmd {
    /// Submission tokens.
    #[command(subcommand)]
    Token(TokenCmd),
}

#[derive(Subcommand)]
pub enum TokenCmd {
    /// Create a token (printed once; the store keeps only its hash).
    Create {
        /// Who the token is for (shown as the owner of its submissions).
        #[arg(long)]
        name: String,
        /// `user` (submits; sees its own submissions), `admin` (sees and cancels all) or `worker` (the worker API:
        /// give it to `vb worker` in VB_WORKER_TOKEN or --token-file).
        #[arg(long, default_value = "user", value_parser = parse_role)]
        role: vb_store::TokenRole,
        /// The service's store (default: `sqlite://out/vb.db`, which must exist: run this where `vb serve` runs).
        #[arg(long)]
        db: Option<String>,
    },
    /// Revoke every token with this name.
    Revoke {
        /// Name of the tokens to revoke.
        #[arg(long)]
        name: String,
        /// The service's store (default: `sqlite://out/vb.db`, which must exist).
        #[arg(long)]
        db: Option<String>,
    },
}

/// The user named by `--planner-user`, if any.
fn planner_user(name: Option<&str>) -> anyhow::Result<Option<vb_worker::sandbox::PlannerUser>> {
    name.map(vb_worker::sandbox::PlannerUser::lookup)
        .transpose()
        .map_err(anyhow::Error::msg)
}

fn parse_role(s: &str) -> Result<vb_store::TokenRole, String> {
    vb_store::TokenRole::parse(s).ok_or_else(|| format!("`{s}` is not user, admin or worker"))
}

/// Waits for Ctrl-C (SIGINT) or SIGTERM (what `docker stop`, systemd and Kubernetes send).
/// A database URL for a log line: the password (and user) of `postgres://user:password@host/db` left out.
fn without_credentials(url: &str) -> String {
    match (url.split_once("://"), url.rsplit_once('@')) {
        (Some((scheme, _)), Some((_, host))) => format!("{scheme}://***@{host}"),
        _ => url.to_string(),
    }
}

/// Ctrl-C (SIGINT) and SIGTERM, caught from the moment this is made: made first thing, so a signal that arrives while
/// a service starts stops it cleanly at its next wait instead of killing it half-started (the default action).
struct StopSignal {
    term: tokio::signal::unix::Signal,
    int: tokio::signal::unix::Signal,
}

impl StopSignal {
    fn new() -> anyhow::Result<StopSignal> {
        use tokio::signal::unix::{signal, SignalKind};
        Ok(StopSignal {
            term: signal(SignalKind::terminate())?,
            int: signal(SignalKind::interrupt())?,
        })
    }

    async fn recv(&mut self) {
        tokio::select! {
            _ = self.term.recv() => {}
            _ = self.int.recv() => {}
        }
    }
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
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

async fn open_store(url: &str) -> anyhow::Result<Store> {
    prepare_db(url)?;
    Store::open(url)
        .await
        .with_context(|| format!("opening the store at {url}"))
}

/// The store to administer: the one `--db` names, or the default `sqlite://out/vb.db`, which must already exist (run
/// from another directory it would be a new, empty store, and its token one no service knows).
async fn admin_store(db: Option<&str>) -> anyhow::Result<Store> {
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

async fn bind(addr: SocketAddr, what: &str) -> anyhow::Result<TcpListener> {
    TcpListener::bind(addr)
        .await
        .with_context(|| format!("cannot listen on {addr} for the {what} (is another vb running? pick another with a flag)"))
}

/// The `Sim` API on the task set in `dir`.
fn sim_service(dir: &std::path::Path) -> anyhow::Result<vb_worker::sim_service::SimService> {
    let set = tasks::TaskSet::load(dir)
        .with_context(|| format!("loading the task set {}", dir.display()))?;
    Ok(vb_worker::sim_service::SimService::new(Arc::new(set)))
}

/// Starts the coordinator's gRPC services on `listener` within `limits`, with the `Sim` API when `sim` is given.
async fn start_coordinator(
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
        let grpc = bind(a.grpc, "coordinator gRPC API").await?;
        let http = bind(a.http, "leaderboard").await?;
        let grpc_addr = grpc.local_addr()?;
        let http_addr = http.local_addr()?;
        let sim = sim_service(&a.task_dir)?;
        let mut ccfg = CoordinatorConfig::new(a.task_dir.clone());
        ccfg.allow_exec = !a.no_exec;
        let coord = start_coordinator(store.clone(), ccfg, grpc, Some(sim), None, &limits).await?;
        let lb = Leaderboard::new(store.reader(), Some(tasks::TaskSet::load(&a.task_dir)?));
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
        let mut cfg = CoordinatorConfig::new(a.task_dir.clone());
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
            let sim = sim_service(&a.task_dir)?;
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

pub fn leaderboard(a: LeaderboardArgs) -> anyhow::Result<()> {
    let limits = a.net.limits()?;
    runtime()?.block_on(async move {
        let mut signal = StopSignal::new()?;
        let reader = vb_store::Reader::open(&a.db)
            .await
            .with_context(|| format!("opening the store at {}", a.db))?;
        let set = tasks::TaskSet::load(&a.task_dir).ok();
        let listener = bind(a.listen, "leaderboard").await?;
        tracing::info!(url = %format!("http://{}/", listener.local_addr()?), "leaderboard listening");
        tokio::select! {
            r = vb_leaderboard::serve_with(Leaderboard::new(reader, set), listener, &limits) => r?,
            _ = signal.recv() => {}
        }
        Ok(())
    })
}

pub fn admin(c: AdminCmd) -> anyhow::Result<()> {
    runtime()?.block_on(async move {
        match c {
            AdminCmd::Token(TokenCmd::Create { name, role, db }) => {
                if name.trim().is_empty() {
                    bail!("--name must not be empty");
                }
                let store = admin_store(db.as_deref()).await?;
                let token = store
                    .create_token(&name, role, vb_coordinator::now())
                    .await?;
                eprintln!(
                    "{} token for `{name}` (shown once; the store keeps only its SHA-256):",
                    role.as_str()
                );
                println!("{token}");
            }
            AdminCmd::Token(TokenCmd::Revoke { name, db }) => {
                let store = admin_store(db.as_deref()).await?;
                let n = store.revoke_tokens(&name).await?;
                println!("revoked {n} token(s) named `{name}`");
            }
        }
        Ok(())
    })
}
