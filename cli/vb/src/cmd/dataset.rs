//! `vb dataset ...`: generate the benchmark's datasets (expert, random exploration, failure cases) in LeRobot v3's
//! layout, and check or summarise one.

use datasets::generate::GenerateConfig;
use datasets::{DatasetKind, SpeedProfile, Variant};
use std::io::Write;
use std::path::PathBuf;

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum Kind {
    Expert,
    Random,
    Failures,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum VariantArg {
    Lite,
    Full,
}

#[derive(Clone, Copy, clap::ValueEnum)]
pub enum ProfileArg {
    Constant,
    StopAndGo,
    Fast,
}

#[derive(clap::Subcommand)]
pub enum DatasetCmd {
    /// Generate (or resume) a dataset on a training task set (`vb tasks generate --seed N`).
    Generate {
        /// expert: successful episodes of a built-in planner (pid by default) on the set's tasks and more drawn
        /// start/goal pairs; random: sinusoidal steering at 2 m/s from starts spread over every world; failures:
        /// the last 10 s before every rollover and stuck of the built-in planners' runs on the set's tasks.
        #[arg(long, value_enum)]
        kind: Kind,
        /// The training task set (the benchmark's own is refused unless --allow-benchmark-tasks).
        #[arg(long)]
        task_set: PathBuf,
        /// Simulated hours to keep.
        #[arg(long)]
        hours: f64,
        /// Output directory (running again with the same arguments resumes).
        #[arg(long)]
        out: PathBuf,
        /// Also write the failure windows of a random or expert run into this dataset.
        #[arg(long)]
        failures_out: Option<PathBuf>,
        #[arg(long, default_value = "hmmwv")]
        vehicle: String,
        /// World scale (default: the vehicle's own).
        #[arg(long)]
        scale: Option<f64>,
        #[arg(long, default_value_t = 0)]
        seed: u64,
        /// Frames per simulated second asked for (the physics step rounds the period: the dataset says the rate).
        #[arg(long, default_value_t = 20.0)]
        control_rate: f64,
        /// lite: no crops (the Python reader rebuilds them); full: float16 elevation and semantics crops.
        #[arg(long, value_enum, default_value = "lite")]
        variant: VariantArg,
        #[arg(long, default_value_t = datasets::generate::DEFAULT_CROP_SIZE)]
        crop_size: usize,
        /// Crop cell size, m (default: 1 m times the world scale).
        #[arg(long)]
        crop_resolution: Option<f64>,
        /// Time limit of a random episode, s.
        #[arg(long, default_value_t = datasets::generate::DEFAULT_MAX_TIME)]
        max_time: f64,
        /// Random exploration's speed command: constant (the paper's 2 m/s), stop-and-go (periodic stops,
        /// alternately braked and coasting, so the data holds standing and starting on slopes) or fast (a speed
        /// drawn per episode from 2 to 8 m/s, so the data holds rollovers).
        #[arg(long, value_enum, default_value = "constant")]
        speed_profile: ProfileArg,
        /// Built-in planners (expert: one, default pid; failures: default pid,eh).
        #[arg(long, value_delimiter = ',')]
        planners: Vec<String>,
        /// Accept the benchmark's own tasks: an analysis dataset, marked analysis_only (never train on it).
        #[arg(long)]
        allow_benchmark_tasks: bool,
        /// Worker threads (default: all cores; the output does not depend on it).
        #[arg(long, default_value_t = 0)]
        threads: usize,
    },
    /// Summarise a dataset: counts, hours, outcome mix.
    Info { dir: PathBuf },
    /// Check a dataset against the format (schema, counts, index continuity, statistics, checksums).
    Validate { dir: PathBuf },
}

pub fn run(cmd: DatasetCmd) -> anyhow::Result<()> {
    match cmd {
        DatasetCmd::Generate {
            kind,
            task_set,
            hours,
            out,
            failures_out,
            vehicle,
            scale,
            seed,
            control_rate,
            variant,
            crop_size,
            crop_resolution,
            max_time,
            speed_profile,
            planners,
            allow_benchmark_tasks,
            threads,
        } => {
            let kind = match kind {
                Kind::Expert => DatasetKind::Expert,
                Kind::Random => DatasetKind::Random,
                Kind::Failures => DatasetKind::Failures,
            };
            let mut cfg = GenerateConfig::new(kind, &task_set, hours);
            cfg.vehicle = vehicle.into();
            cfg.scale = scale;
            cfg.seed = seed;
            cfg.control_rate_hz = control_rate;
            cfg.variant = match variant {
                VariantArg::Lite => Variant::Lite,
                VariantArg::Full => Variant::Full,
            };
            cfg.crop_size = crop_size;
            cfg.crop_resolution = crop_resolution;
            cfg.max_time = max_time;
            cfg.speed_profile = match speed_profile {
                ProfileArg::Constant => SpeedProfile::Constant,
                ProfileArg::StopAndGo => SpeedProfile::StopAndGo,
                ProfileArg::Fast => SpeedProfile::Fast,
            };
            if !planners.is_empty() {
                cfg.planners = planners;
            }
            cfg.allow_benchmark_tasks = allow_benchmark_tasks;
            cfg.threads = threads;
            let progress = |p: &datasets::generate::GenerateProgress| print_progress(p, hours);
            let g = datasets::cli::generate(
                &cfg,
                &out,
                failures_out.as_deref(),
                &recorded_command(),
                &progress,
            )?;
            eprintln!();
            print_generated(&g);
        }
        DatasetCmd::Info { dir } => print!("{}", datasets::info(&dir)?),
        DatasetCmd::Validate { dir } => {
            let report = datasets::validate(&dir)?;
            print!("{report}");
            anyhow::ensure!(
                report.is_ok(),
                "{} is not a valid, complete dataset",
                dir.display()
            );
        }
    }
    Ok(())
}

/// The command line as the dataset records it: without what does not change the content (`--threads`), so a
/// resumed or re-run dataset keeps identical bytes.
fn recorded_command() -> String {
    let command: Vec<String> = std::env::args()
        .collect::<Vec<_>>()
        .split(|a| a == "--threads")
        .enumerate()
        .flat_map(|(i, part)| part.iter().skip(usize::from(i > 0)).cloned())
        .collect();
    command.join(" ")
}

fn print_progress(p: &datasets::generate::GenerateProgress, hours: f64) {
    eprint!(
        "\r{:.2} of {:.2} simulated hours kept, {} episodes, {} failure windows ",
        p.kept_frames as f64 / p.target_frames.max(1) as f64 * hours,
        hours,
        p.kept_episodes,
        p.failure_windows
    );
    let _ = std::io::stderr().flush();
}

fn print_generated(g: &datasets::cli::Generated) {
    println!(
        "{}: {} episodes, {} frames, {:.2} simulated hours ({} episodes simulated by this run, outcomes {:?})",
        g.main.dir.display(),
        g.main.episodes,
        g.main.frames,
        g.main.simulated_hours,
        g.run.episodes_run,
        g.run.outcomes
    );
    if let Some(f) = &g.failures {
        println!(
            "{}: {} failure windows ({:?})",
            f.dir.display(),
            f.episodes,
            g.run.windows
        );
    }
}
