//! The arguments of the service's subcommands (clap).

use crate::cmd::net_args::NetArgs;
use clap::{Args, Subcommand};
use std::net::SocketAddr;
use std::path::PathBuf;

/// Who may use the `Sim` API (`vb worker --sim`, `vb serve`'s gRPC port) and how long an unused episode stays.
#[derive(Args, Clone, Debug)]
#[command(next_help_heading = "The Sim API's access")]
pub struct SimAccessArgs {
    /// File of Sim API tokens, one per line (clients send `authorization: Bearer <token>`); else the tokens in
    /// VB_SIM_TOKEN (comma-separated). Without any, the Sim API serves only clients on this machine.
    #[arg(long)]
    pub sim_token_file: Option<PathBuf>,
    /// A Sim episode that no call touches for this long is closed, s.
    #[arg(long, default_value_t = 600.0)]
    pub sim_idle_timeout_s: f64,
}

impl SimAccessArgs {
    pub fn access(&self) -> anyhow::Result<vb_worker::sim_access::SimAccess> {
        use anyhow::Context;
        let s = self.sim_idle_timeout_s;
        anyhow::ensure!(
            s.is_finite() && s > 0.0 && s <= 86_400.0,
            "--sim-idle-timeout-s must be a positive number of seconds, at most a day (got {s})"
        );
        let tokens: Vec<String> = match &self.sim_token_file {
            Some(p) => std::fs::read_to_string(p)
                .with_context(|| format!("reading the Sim API tokens from {}", p.display()))?
                .lines()
                .map(str::to_string)
                .collect(),
            None => std::env::var("VB_SIM_TOKEN")
                .unwrap_or_default()
                .split(',')
                .map(str::to_string)
                .collect(),
        };
        Ok(vb_worker::sim_access::SimAccess::with_tokens(tokens)
            .with_idle(std::time::Duration::from_secs_f64(s)))
    }
}

fn default_slots() -> usize {
    std::thread::available_parallelism().map_or(2, |n| n.get())
}

#[derive(Args)]
pub struct ServeArgs {
    /// Results store (SQLite file or postgres:// URL).
    #[arg(long, default_value = "sqlite://out/vb.db")]
    pub(super) db: String,
    /// gRPC address of the coordinator (submission and worker APIs, and the Sim API).
    #[arg(long, default_value = "127.0.0.1:50051")]
    pub(super) grpc: SocketAddr,
    /// HTTP address of the leaderboard.
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub(super) http: SocketAddr,
    /// Episodes run at once by the in-process worker pool.
    #[arg(long, default_value_t = default_slots())]
    pub(super) slots: usize,
    /// Task-set directory (default: the benchmark's set this binary carries, unpacked into ~/.cache/vertibench/tasks/VERSION).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::embedded::default_dir(), hide_default_value = true)]
    pub(super) task_dir: PathBuf,
    /// Submit this built-in planner through the gRPC API and follow it to the end.
    #[arg(long)]
    pub(super) evaluate: Option<String>,
    /// Tasks of that evaluation: `all`, or world ids and task ids.
    #[arg(long, default_value = "all")]
    pub(super) tasks: String,
    /// Stop once the evaluation has finished instead of serving on.
    #[arg(long)]
    pub(super) exit_when_done: bool,
    /// Refuse exec and image planners (untrusted code; exec planners run as this process's user): only endpoints
    /// and built-ins. Use it whenever strangers can submit.
    #[arg(long)]
    pub(super) no_exec: bool,
    /// Run exec planners as this unprivileged user (needs root), so they cannot read the service's files.
    #[arg(long)]
    pub(super) planner_user: Option<String>,
    #[command(flatten)]
    pub(super) sim_access: SimAccessArgs,
    #[command(flatten)]
    pub(super) net: NetArgs,
}

#[derive(Args)]
pub struct CoordinatorArgs {
    /// Results store: a SQLite file (`sqlite://PATH`) or a PostgreSQL URL; the coordinator is its only writer.
    #[arg(long, default_value = "sqlite://out/vb.db")]
    pub(super) db: String,
    /// gRPC address of the submission and worker APIs.
    #[arg(long, default_value = "127.0.0.1:50051")]
    pub(super) listen: SocketAddr,
    /// Task-set directory (default: the benchmark's set this binary carries, unpacked into ~/.cache/vertibench/tasks/VERSION).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::embedded::default_dir(), hide_default_value = true)]
    pub(super) task_dir: PathBuf,
    /// Lease length without a heartbeat, s: a dead worker's episodes are re-queued after this.
    #[arg(long, default_value_t = 30.0)]
    pub(super) lease_s: f64,
    /// Heartbeat period asked of workers, s.
    #[arg(long, default_value_t = 5.0)]
    pub(super) heartbeat_s: f64,
    /// Refuse exec and image planners (only endpoints and built-ins).
    #[arg(long)]
    pub(super) no_exec: bool,
    /// A worker token whose workers drop this many leases (expired or released without a result) within
    /// --drop-window-s gets no new leases until the window has passed.
    #[arg(long, default_value_t = 32)]
    pub(super) max_dropped_leases: u64,
    /// The window of --max-dropped-leases and --max-handed-back-leases, s.
    #[arg(long, default_value_t = 600.0)]
    pub(super) drop_window_s: f64,
    /// A worker token whose workers hand back this many leases unrun (stopping workers do, and workers refusing a
    /// submission they cannot run, without using an attempt) within --drop-window-s gets no new leases until fewer remain in the window: a budget of its own,
    /// so draining workers are not throttled but a token leasing and handing back in a loop is.
    #[arg(long, default_value_t = 256)]
    pub(super) max_handed_back_leases: u64,
    /// Serve gRPC over TLS with this certificate chain (PEM); clients then connect to https://.
    #[arg(long, requires = "tls_key")]
    pub(super) tls_cert: Option<PathBuf>,
    /// The private key (PEM) of --tls-cert.
    #[arg(long, requires = "tls_cert")]
    pub(super) tls_key: Option<PathBuf>,
    #[command(flatten)]
    pub(super) net: NetArgs,
}

#[derive(Args)]
pub struct WorkerArgs {
    /// The coordinator's URL (https:// for TLS).
    #[arg(long, default_value = "http://127.0.0.1:50051")]
    pub(super) coordinator: String,
    /// CA certificate (PEM) to verify an https:// coordinator against (default: the public web PKI roots).
    #[arg(long, env = "VB_TLS_CA")]
    pub(super) tls_ca: Option<PathBuf>,
    /// Episodes run at once (default: the number of cores).
    #[arg(long, default_value_t = default_slots())]
    pub(super) slots: usize,
    /// Name shown in the coordinator's logs.
    #[arg(long)]
    pub(super) name: Option<String>,
    /// Task-set directory (default: the benchmark's set this binary carries, unpacked into ~/.cache/vertibench/tasks/VERSION).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::embedded::default_dir(), hide_default_value = true)]
    pub(super) task_dir: PathBuf,
    /// How long a planner process may take to start serving, s.
    #[arg(long, default_value_t = 30.0)]
    pub(super) planner_startup_s: f64,
    /// Also serve the client-driven `Sim` gRPC API on this address (e.g. 127.0.0.1:50052).
    #[arg(long)]
    pub(super) sim: Option<SocketAddr>,
    /// Do not run exec or image planners (they are untrusted code; exec planners run as this worker's user).
    #[arg(long)]
    pub(super) no_exec: bool,
    /// Refused: a token on the command line is readable by every process on the machine (`/proc/PID/cmdline`).
    /// Give the worker token (`vb admin token create --role worker`) in the environment variable VB_WORKER_TOKEN or
    /// in a file (--token-file).
    #[arg(long, hide = true)]
    pub(super) token: Option<String>,
    /// File holding the worker token (`vb admin token create --role worker`; one line). Without it the token is read
    /// from the environment variable VB_WORKER_TOKEN. Never on the command line.
    #[arg(long)]
    pub(super) token_file: Option<PathBuf>,
    /// Run exec planners as this unprivileged user (needs root), so they cannot read the worker's files.
    #[arg(long)]
    pub(super) planner_user: Option<String>,
    /// On SIGTERM or Ctrl-C, seconds running episodes get to finish before the rest are stopped and handed back to
    /// the queue (keep it below the time the process manager waits before SIGKILL).
    #[arg(long, default_value_t = 20.0)]
    pub(super) drain_s: f64,
    #[command(flatten)]
    pub(super) sim_access: SimAccessArgs,
    #[command(flatten)]
    pub(super) net: NetArgs,
}

#[derive(Args)]
pub struct LeaderboardArgs {
    /// Results store to read (the coordinator's).
    #[arg(long, default_value = "sqlite://out/vb.db")]
    pub(super) db: String,
    /// HTTP address of the pages and the JSON API.
    #[arg(long, default_value = "127.0.0.1:8080")]
    pub(super) listen: SocketAddr,
    /// Task-set directory (default: the benchmark's set this binary carries, unpacked into ~/.cache/vertibench/tasks/VERSION).
    #[arg(long, env = "VB_TASK_DIR", default_value_os_t = tasks::embedded::default_dir(), hide_default_value = true)]
    pub(super) task_dir: PathBuf,
    #[command(flatten)]
    pub(super) net: NetArgs,
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

fn parse_role(s: &str) -> Result<vb_store::TokenRole, String> {
    vb_store::TokenRole::parse(s).ok_or_else(|| format!("`{s}` is not user, admin or worker"))
}
