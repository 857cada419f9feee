//! `vb`: the vertibench command line. Thin: parses arguments and calls library code.

use clap::{Parser, Subcommand};

mod cmd;

#[derive(Parser)]
#[command(
    name = "vb",
    version,
    about = "vertibench: off-road mobility benchmark on vertically challenging terrain"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Generate, inspect, render and import task sets.
    #[command(subcommand)]
    Tasks(cmd::tasks::TasksCmd),
    /// Train, evaluate, calibrate and render the SWAE terrain generator.
    #[command(subcommand)]
    Terrain(cmd::terrain::TerrainCmd),
    /// Run single simulated episodes.
    #[command(subcommand)]
    Sim(cmd::sim::SimCmd),
    /// Generate, check and summarise the datasets (expert, random exploration, failure cases; LeRobot v3).
    #[command(subcommand)]
    Dataset(cmd::dataset::DatasetCmd),
    /// Evaluate a planner on the task set, locally and in parallel.
    Eval(cmd::eval::EvalArgs),
    /// Compare two evaluation results on the same tasks with paired statistics.
    Compare(cmd::compare::CompareArgs),
    /// Write a static leaderboard page from evaluation directories.
    #[command(name = "leaderboard-static")]
    Leaderboard(cmd::leaderboard::LeaderboardArgs),
    /// Run the whole evaluation service in one process (coordinator, leaderboard, workers) on SQLite.
    Serve(cmd::service::ServeArgs),
    /// Run the coordinator (submission and worker gRPC APIs; the only writer of the store).
    Coordinator(cmd::service::CoordinatorArgs),
    /// Run a worker that leases episodes from a coordinator.
    Worker(cmd::service::WorkerArgs),
    /// Serve the HTTP leaderboard from a store (also `vb leaderboard-static` for a page from `vb eval` output).
    #[command(name = "leaderboard")]
    LeaderboardServer(cmd::service::LeaderboardArgs),
    /// Administration of the service (tokens).
    #[command(subcommand)]
    Admin(cmd::service::AdminCmd),
    /// Measure performance.
    #[command(subcommand)]
    Bench(cmd::bench::BenchCmd),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // A printing command ends quietly on a closed pipe (`vb tasks stats | head`); a server keeps SIGPIPE ignored (the
    // Rust runtime's default), so a peer that closes its connection mid-write costs that connection an EPIPE, not
    // the process its life (hyper writes with writev, which cannot suppress the signal per call).
    if !cli.command.is_server() {
        vb_submit::cli::restore_sigpipe();
    }
    init_logging();
    // The benchmark's task set, carried in this binary, into its versioned cache directory (every file checked)
    // where the commands' default `--task-dir` points (not needed when VB_TASK_DIR names another).
    if std::env::var_os("VB_TASK_DIR").is_none() {
        if let Err(e) = tasks::embedded::committed_dir() {
            tracing::warn!(error = %e, "the benchmark's task set this binary carries is not in place");
        }
    }
    vb_submit::cli::exit_code(run(cli))
}

impl Command {
    /// Whether this command talks to peers over the network (servers, and `vb bench`'s planner and leaderboard
    /// loads): those must outlive any one connection.
    fn is_server(&self) -> bool {
        matches!(
            self,
            Command::Serve(_)
                | Command::Coordinator(_)
                | Command::Worker(_)
                | Command::LeaderboardServer(_)
                | Command::Bench(_)
        )
    }
}

/// The service processes' logs: one line per event on stderr with an RFC 3339 UTC time, the level, the module and
/// the event's fields (`worker=... task=...`); the level from `VB_LOG` (error, warn, info, debug, trace; default
/// info).
fn init_logging() {
    let level = std::env::var("VB_LOG")
        .ok()
        .and_then(|v| v.parse::<tracing::Level>().ok())
        .unwrap_or(tracing::Level::INFO);
    let _ = tracing_subscriber::fmt()
        .with_max_level(level)
        .with_writer(std::io::stderr)
        .try_init();
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Tasks(c) => cmd::tasks::run(c),
        Command::Terrain(c) => cmd::terrain::run(c),
        Command::Sim(c) => cmd::sim::run(c),
        Command::Eval(a) => cmd::eval::run(a),
        Command::Dataset(c) => cmd::dataset::run(c),
        Command::Compare(a) => cmd::compare::run(a),
        Command::Leaderboard(a) => cmd::leaderboard::run(a),
        Command::Bench(c) => cmd::bench::run(c),
        Command::Serve(a) => cmd::service::serve(a),
        Command::Coordinator(a) => cmd::service::coordinator(a),
        Command::Worker(a) => cmd::service::worker(a),
        Command::LeaderboardServer(a) => cmd::service::leaderboard(a),
        Command::Admin(c) => cmd::service::admin(c),
    }
}
