//! `vb-submit`: submit a planner to a vertibench coordinator, follow it, fetch its results. Thin: parses arguments
//! and calls the `vb_submit` library.

use anyhow::bail;
use clap::{Args, Parser, Subcommand};
use contracts::input::shown;
use std::path::PathBuf;
use vb_proto::v1 as pb;
use vb_proto::ProtoEnum;

// Standard output through `cli::out`: a closed pipe ends the program quietly while SIGPIPE stays ignored (a socket
// closed mid-write is an error that says so, never a silent death by signal).
macro_rules! println {
    () => {
        vb_submit::cli::out(format_args!("\n"))
    };
    ($($t:tt)*) => {
        vb_submit::cli::out(format_args!("{}\n", format_args!($($t)*)))
    };
}
macro_rules! print {
    ($($t:tt)*) => {
        vb_submit::cli::out(format_args!($($t)*))
    };
}

#[derive(Parser)]
#[command(
    name = "vb-submit",
    version,
    about = "Submit off-road planners to a vertibench evaluation service"
)]
struct Cli {
    /// Coordinator URL.
    #[arg(
        long,
        env = "VB_COORDINATOR",
        default_value = "http://127.0.0.1:50051",
        global = true
    )]
    coordinator: String,
    /// Submission token (from `vb admin token create`); else $VB_TOKEN, else ~/.config/vertibench/token.
    #[arg(long, env = "VB_TOKEN", hide_env_values = true, global = true)]
    token: Option<String>,
    /// CA certificate (PEM) to verify an https:// coordinator against (default: the public web PKI roots).
    #[arg(long, env = "VB_TLS_CA", global = true)]
    tls_ca: Option<std::path::PathBuf>,
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Args, Clone)]
struct SubmitOpts {
    /// Name shown on the leaderboard.
    #[arg(long)]
    name: Option<String>,
    /// Vehicle (see `vb sim vehicles`).
    #[arg(long, default_value = "hmmwv")]
    vehicle: String,
    /// World scale (0 = the vehicle's own).
    #[arg(long, default_value_t = 0.0)]
    scale: f64,
    /// `all`, or a comma-separated list of world ids and task ids (w017-t3).
    #[arg(long, default_value = "all")]
    tasks: String,
    /// Per-control-step deadline of the planner, s.
    #[arg(long, default_value_t = 1.0)]
    step_deadline: f64,
    /// Seed of the episodes (none of the default physics is random; it seeds the perception noise).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Perception profiles, comma-separated (ideal, nominal, degraded): one submission per profile, in one
    /// family, whose page shows each profile's success and its paired drop from ideal. Default: ideal.
    #[arg(long, value_delimiter = ',', default_value = "ideal")]
    perception: Vec<String>,
    /// Follow the progress until the submission ends.
    #[arg(long)]
    wait: bool,
}

#[derive(Subcommand)]
enum Cmd {
    /// Submit a planner server you run (gRPC `vertibench.v1.Planner` at URL).
    Endpoint {
        url: String,
        #[command(flatten)]
        opts: SubmitOpts,
    },
    /// Submit a command that workers start; it must serve the Planner API on $VB_PLANNER_ADDR.
    Exec {
        #[command(flatten)]
        opts: SubmitOpts,
        /// The command that serves the planner on $VB_PLANNER_ADDR (relative file arguments are made absolute).
        #[arg(last = true, required = true)]
        command: Vec<String>,
    },
    /// Submit a container image that serves the Planner API on $VB_PLANNER_ADDR (a Unix socket: no network).
    Image {
        image: String,
        #[command(flatten)]
        opts: SubmitOpts,
    },
    /// Submit one of the built-in planners (pid, eh, mppi, mppi-release, mppi6-oracle; rl, mcl, acl, mppi6, wmvct,
    /// tal, tnt where the service's build has their weights).
    Builtin {
        planner: String,
        #[command(flatten)]
        opts: SubmitOpts,
    },
    /// Progress of one submission (progress bar, queue position, ETA), or of all of them.
    Status {
        id: Option<String>,
        /// Follow until the submission ends.
        #[arg(long)]
        watch: bool,
    },
    /// Results of a submission in `vb eval`'s formats: its finished episodes as episodes.csv's columns (csv) or as
    /// results.jsonl's rows with the status and the unfinished episodes (json), on stdout; or, with --out, the
    /// directory `vb eval` writes, for `vb compare` and `vb leaderboard-static`.
    Results {
        id: String,
        /// Format on stdout.
        #[arg(long, default_value = "csv", value_parser = ["csv", "json"])]
        format: String,
        /// Write vb eval's files (results.jsonl, episodes.csv, episodes.parquet, summary.json, summary.txt,
        /// charts.svg) into this new or empty directory instead.
        #[arg(long)]
        out: Option<PathBuf>,
        /// With --out: also write each finished episode's planner log to DIR/logs/TASK.log (yours only).
        #[arg(long, requires = "out")]
        logs: bool,
    },
    /// Print one episode's planner log (stdout and stderr of the planner): only the submission's owner sees it.
    Log {
        id: String,
        /// Task id, e.g. w001-t0.
        task: contracts::TaskId,
    },
    /// Cancel a submission: finished episodes are kept, the rest are marked not run.
    Cancel { id: String },
    /// Check a planner on one short task locally before queueing the whole benchmark.
    Validate {
        #[command(subcommand)]
        what: ValidateCmd,
    },
}

#[derive(Subcommand)]
enum ValidateCmd {
    /// A planner server at URL.
    Endpoint {
        url: String,
        #[command(flatten)]
        v: ValidateOpts,
    },
    /// A command serving on $VB_PLANNER_ADDR.
    Exec {
        #[command(flatten)]
        v: ValidateOpts,
        /// The command that serves the planner on $VB_PLANNER_ADDR.
        #[arg(last = true, required = true)]
        command: Vec<String>,
    },
}

#[derive(Args, Clone)]
struct ValidateOpts {
    /// The task to run.
    #[arg(long, default_value = "w001-t0")]
    task: String,
    /// Simulated seconds to run.
    #[arg(long, default_value_t = 15.0)]
    max_time: f64,
    /// Per-control-step deadline of the planner, s.
    #[arg(long, default_value_t = 1.0)]
    step_deadline: f64,
    /// Task-set directory (default: the benchmark's set this binary carries, unpacked into ~/.cache/vertibench/tasks/VERSION).
    #[arg(long)]
    task_dir: Option<PathBuf>,
    /// Run an exec planner as this user, as a worker with `--planner-user` does (needs root).
    #[arg(long)]
    planner_user: Option<String>,
    /// Perception profile (ideal, nominal, degraded, or a TOML file): check the planner with the estimated state and,
    /// under nominal or degraded, the believed maps and their updates, as a submission under it gets them.
    #[arg(long, default_value = "ideal")]
    perception: String,
}

fn token(cli: &Cli) -> anyhow::Result<String> {
    if let Some(t) = &cli.token {
        return Ok(t.clone());
    }
    let path = std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".config/vertibench/token"));
    if let Some(p) = &path {
        if let Ok(t) = std::fs::read_to_string(p) {
            return Ok(t.trim().to_string());
        }
    }
    bail!("no token: pass --token, set VB_TOKEN, or put one in ~/.config/vertibench/token (an operator creates it with `vb admin token create --name YOU`)")
}

async fn do_submit(
    cli: &Cli,
    planner: pb::planner_ref::Kind,
    default_name: String,
    o: &SubmitOpts,
) -> anyhow::Result<()> {
    let task_ids: Vec<String> = if o.tasks.trim() == "all" {
        Vec::new()
    } else {
        o.tasks
            .split(',')
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect()
    };
    if task_ids.is_empty() && o.tasks.trim() != "all" {
        bail!("--tasks is empty: pass `all`, or world ids and task ids (17,w018-t3)");
    }
    let mut client =
        vb_submit::connect(&cli.coordinator, &token(cli)?, cli.tls_ca.as_deref()).await?;
    let r = vb_submit::submit(
        &mut client,
        pb::SubmitRequest {
            name: o.name.clone().unwrap_or(default_name),
            planner: Some(pb::PlannerRef {
                kind: Some(planner),
            }),
            vehicle: o.vehicle.clone(),
            scale: o.scale,
            task_ids,
            step_deadline_s: o.step_deadline,
            seed: o.seed,
            perception: o.perception.clone(),
        },
    )
    .await?;
    println!("submitted {} ({} episodes)", r.submission_id, r.episodes);
    if r.submission_ids.len() > 1 {
        for (id, profile) in r.submission_ids.iter().zip(&o.perception) {
            println!("  {id}: perception {profile}");
        }
    }
    let ids = if r.submission_ids.is_empty() {
        vec![r.submission_id.clone()]
    } else {
        r.submission_ids.clone()
    };
    for id in &ids {
        if o.wait {
            wait_for(&mut client, id).await?;
        } else {
            println!("follow it with: vb-submit status {id} --watch");
        }
    }
    Ok(())
}

/// Follows submission `id` until it ends; fails when any of its episodes failed because of the planner or the
/// infrastructure.
async fn wait_for(client: &mut vb_submit::Client, id: &str) -> anyhow::Result<()> {
    let last = vb_submit::watch(client, id, |s| {
        eprint!("\r{}   ", vb_submit::status_line(s))
    })
    .await?;
    eprintln!();
    println!("{}", vb_submit::status_line(&last));
    // Episodes that failed because of the planner or the infrastructure (not by how the vehicle drove) make
    // the command fail: a script waiting on it must not take them for results.
    let results = vb_submit::results(client, id).await?;
    let finished = results
        .episodes
        .iter()
        .filter(|e| e.outcome.is_some())
        .count();
    let broken: Vec<_> = results
        .episodes
        .iter()
        .filter(|e| {
            e.outcome
                .and_then(|o| contracts::RecordedOutcome::from_wire(o).ok())
                .is_some_and(|o| o.is_failure_of_planner_or_infrastructure())
        })
        .collect();
    if let Some(first) = broken.first() {
        bail!(
            "{} of {finished} finished episodes failed because of the planner or the infrastructure (first: {} \
             {}: {}): see `vb-submit results {} --format json`",
            broken.len(),
            first.task_id,
            first
                .reason
                .and_then(|r| contracts::EndReason::from_wire(r).ok())
                .map_or("unknown reason", contracts::EndReason::as_str),
            shown(&first.detail),
            id
        );
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // SIGPIPE stays ignored (the Rust runtime's default): every command talks over a socket, and a peer that closes
    // mid-write must cost a clear error, not a silent exit 141; printing into a closed pipe ends quietly (`print!`).
    let result = tokio::runtime::Runtime::new()
        .map_err(anyhow::Error::from)
        .and_then(|rt| rt.block_on(run(cli)));
    vb_submit::cli::exit_code(result)
}

async fn run(cli: Cli) -> anyhow::Result<()> {
    use pb::planner_ref::Kind;
    match &cli.command {
        Cmd::Endpoint { url, opts } => {
            do_submit(&cli, Kind::Endpoint(url.clone()), url.clone(), opts).await
        }
        Cmd::Exec { opts, command } => {
            // The command's file names, at most 100 characters (the coordinator's limit on names).
            let name: String = command
                .iter()
                .map(|a| a.rsplit('/').next().unwrap_or(a))
                .collect::<Vec<_>>()
                .join(" ")
                .chars()
                .take(100)
                .collect();
            do_submit(
                &cli,
                Kind::Exec(pb::ExecPlanner {
                    argv: vb_submit::absolute_paths(command),
                }),
                name,
                opts,
            )
            .await
        }
        Cmd::Image { image, opts } => {
            do_submit(&cli, Kind::Image(image.clone()), image.clone(), opts).await
        }
        Cmd::Builtin { planner, opts } => {
            do_submit(&cli, Kind::Builtin(planner.clone()), planner.clone(), opts).await
        }
        Cmd::Status { id, watch } => status(&cli, id.as_deref(), *watch).await,
        Cmd::Results {
            id,
            format,
            out,
            logs,
        } => results_cmd(&cli, id, format, out.as_deref(), *logs).await,
        Cmd::Log { id, task } => {
            let mut client =
                vb_submit::connect(&cli.coordinator, &token(&cli)?, cli.tls_ca.as_deref()).await?;
            let log = vb_submit::episode_log(&mut client, id, *task).await?;
            print!("{log}");
            Ok(())
        }
        Cmd::Cancel { id } => {
            let mut client =
                vb_submit::connect(&cli.coordinator, &token(&cli)?, cli.tls_ca.as_deref()).await?;
            let s = vb_submit::cancel(&mut client, id).await?;
            println!("{}", vb_submit::status_line(&s));
            Ok(())
        }
        Cmd::Validate { what } => validate(what).await,
    }
}

/// `vb-submit status`: every submission of the caller, or one (watched until it ends).
async fn status(cli: &Cli, id: Option<&str>, watch: bool) -> anyhow::Result<()> {
    let mut client =
        vb_submit::connect(&cli.coordinator, &token(cli)?, cli.tls_ca.as_deref()).await?;
    match id {
        None => {
            let all = vb_submit::list(&mut client).await?;
            if all.is_empty() {
                println!("no submissions");
            }
            for s in all {
                println!("{}", vb_submit::list_line(&s));
            }
        }
        Some(id) if watch => {
            let last = vb_submit::watch(&mut client, id, |s| {
                eprint!("\r{}   ", vb_submit::status_line(s))
            })
            .await?;
            eprintln!();
            println!("{}", vb_submit::status_line(&last));
        }
        Some(id) => println!(
            "{}",
            vb_submit::status_line(&vb_submit::status(&mut client, id).await?)
        ),
    }
    Ok(())
}

/// `vb-submit results`: a submission's results as CSV or JSON, or written to a directory (with the planner logs).
async fn results_cmd(
    cli: &Cli,
    id: &str,
    format: &str,
    out: Option<&std::path::Path>,
    logs: bool,
) -> anyhow::Result<()> {
    let mut client =
        vb_submit::connect(&cli.coordinator, &token(cli)?, cli.tls_ca.as_deref()).await?;
    let r = vb_submit::results(&mut client, id).await?;
    let unfinished = vb_submit::results::unfinished(&r)?;
    if !unfinished.is_empty() {
        eprintln!(
            "note: {} of {} episodes have not finished (first: {} {}); the results hold the finished ones",
            unfinished.len(),
            r.episodes.len(),
            unfinished[0].0,
            unfinished[0].1
        );
    }
    match out {
        Some(dir) => {
            let mut s = vb_submit::results::write_dir(dir, &r)?;
            s.planner = shown(&s.planner).into_owned().into();
            print!("{}", results::report::summary_text(&s));
            if logs {
                let n = vb_submit::write_logs(&mut client, &r, &dir.join("logs")).await?;
                println!("wrote {n} planner logs in {}", dir.join("logs").display());
            }
            println!("wrote {}", dir.display());
        }
        None if format == "json" => {
            print!("{}", vb_submit::results::json(&r)?)
        }
        None => print!("{}", vb_submit::results::csv(&r)?),
    }
    Ok(())
}

#[cfg(feature = "validate")]
async fn validate(what: &ValidateCmd) -> anyhow::Result<()> {
    use pb::planner_ref::Kind;
    {
        let (planner, v) = match what {
            ValidateCmd::Endpoint { url, v } => (Kind::Endpoint(url.clone()), v),
            ValidateCmd::Exec { v, command } => (
                Kind::Exec(pb::ExecPlanner {
                    argv: vb_submit::absolute_paths(command),
                }),
                v,
            ),
        };
        let r = vb_submit::validate(
            pb::PlannerRef {
                kind: Some(planner),
            },
            &match &v.task_dir {
                Some(d) => d.clone(),
                None => tasks::embedded::committed_dir()?,
            },
            &v.task,
            v.max_time,
            v.step_deadline,
            v.planner_user.as_deref(),
            &v.perception,
        )
        .await?;
        if let Some(why) = &r.unisolated {
            eprintln!("note: the planner ran without namespaces of its own ({why}); a worker here would refuse it");
        }
        println!(
                "task {}: {} control steps, then the episode ended ({}: {}); round trip p50 {:.2} ms, p99 {:.2} ms, max {:.2} ms",
                v.task, r.control_steps, r.outcome, r.reason, r.round_trip_p50_ms, r.round_trip_p99_ms, r.round_trip_max_ms
            );
        if !r.detail.is_empty() {
            println!("detail: {}", r.detail);
        }
        if !r.planner_log.is_empty() {
            println!("planner log:\n{}", r.planner_log.trim_end());
        }
        if r.ok {
            println!("OK: the planner follows the protocol (a short episode's outcome says nothing of its skill)");
            Ok(())
        } else {
            bail!("the planner failed validation: {} ({})", r.reason, r.detail)
        }
    }
}

#[cfg(not(feature = "validate"))]
async fn validate(_: &ValidateCmd) -> anyhow::Result<()> {
    bail!(
        "this vb-submit was built without `validate` (it links the worker and the simulator): build it with \
         `cargo build --release -p vb-submit --features validate`"
    )
}
