//! `vb tasks ...`: generate, inspect, render and import task sets.

use clap::{Subcommand, ValueEnum};
use sim_core::world::SemanticsKind;
use std::path::PathBuf;
use tasks::TaskSet;

/// Where a generated set's heights come from (`vb tasks generate --generator`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Generator {
    /// The calibrated band-spectrum generator of set v2 (`tasks::interim::BandedSource`).
    Interim,
    /// The 1/f spectral generator of set v1 (`tasks::interim::SpectralSource`).
    #[value(name = "interim-v1")]
    InterimV1,
    /// The SWAE decoder (crate `swae`) of the committed set v3.
    Swae,
}

#[derive(Subcommand)]
pub enum TasksCmd {
    /// Generate the 100-world task set from a seed (byte-identical for the same seed and generator).
    Generate {
        /// Output directory (required: the benchmark's committed set is tasks/data/v4; name it to regenerate it).
        #[arg(long)]
        out: PathBuf,
        #[arg(long, default_value_t = tasks::generate::DEFAULT_SEED)]
        seed: u64,
        /// Height source: `swae` (the SWAE decoder with the committed weights and calibration: the committed set
        /// v3), `interim` (the calibrated band-spectrum generator of set v2) or `interim-v1` (the 1/f generator of
        /// set v1).
        #[arg(long, value_enum, default_value_t = Generator::Swae)]
        generator: Generator,
        /// SWAE weights file instead of the committed one (only with `--generator swae`).
        #[arg(long)]
        weights: Option<PathBuf>,
        /// Height, m, of a decoded +1 at the high level for `--generator swae` (default: the committed weights'
        /// calibrated value; `vb terrain calibrate --weights W` derives it for other weights).
        #[arg(long)]
        full_scale: Option<f64>,
        /// Surface counterfactual: every world keeps its heights, obstacles, tasks and paths but gets ground of this
        /// semantics kind (`rigid`, `mixed` or `deformable`). Evaluating a planner on the three counterfactuals
        /// pairs each task with itself on the three kinds (`vb compare`); the set gets its own version.
        #[arg(long, value_parser = parse_kind)]
        surface: Option<SemanticsKind>,
    },
    /// Print the composition and per-level geometry statistics.
    Stats {
        #[arg(long)]
        dir: Option<PathBuf>,
        /// Print JSON instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Render worlds (hill shade, semantics, obstacles, start/goal, paths) and a contact sheet as PNG.
    Render {
        #[arg(long)]
        dir: Option<PathBuf>,
        /// World ids (all when omitted).
        #[arg(long, value_delimiter = ',')]
        world: Vec<u32>,
        /// Pixels per map sample.
        #[arg(long, default_value_t = 4)]
        ppm: u32,
        #[arg(long, default_value = "out/render")]
        out: PathBuf,
    },
    /// Convert a clone of the original Verti-Bench release (its sampled_maps folder) into our format.
    ImportVertiBench {
        /// The release's `envs/data/BenchMaps/sampled_maps` (or the clone's root).
        path: PathBuf,
        #[arg(long, default_value = "out/verti-bench-imported")]
        out: PathBuf,
    },
}

fn parse_kind(s: &str) -> Result<SemanticsKind, String> {
    SemanticsKind::parse(s)
        .map_err(|_| format!("unknown semantics kind `{s}`: use rigid, mixed or deformable"))
}

/// Whether two paths name the same directory (when both exist).
fn same_dir(a: &std::path::Path, b: &std::path::Path) -> bool {
    matches!((a.canonicalize(), b.canonicalize()), (Ok(x), Ok(y)) if x == y)
}

fn open(dir: Option<PathBuf>) -> anyhow::Result<TaskSet> {
    Ok(TaskSet::load(
        &dir.unwrap_or_else(tasks::embedded::default_dir),
    )?)
}

pub fn run(cmd: TasksCmd) -> anyhow::Result<()> {
    match cmd {
        TasksCmd::Generate {
            out,
            seed,
            generator,
            weights,
            full_scale,
            surface,
        } => {
            anyhow::ensure!(
                full_scale.is_none() || generator == Generator::Swae,
                "--full-scale only applies to --generator swae"
            );
            anyhow::ensure!(
                surface.is_none() || !same_dir(&out, &TaskSet::default_dir()),
                "--surface makes a counterfactual, never the benchmark's committed set: give another --out DIR"
            );
            let source: Box<dyn tasks::generate::HeightSource> = match (generator, weights) {
                (Generator::Swae, None) => Box::new(swae::SwaeSource::from_bytes(
                    swae::source::DEFAULT_WEIGHTS,
                    std::path::Path::new(swae::source::DEFAULT_WEIGHTS_PATH),
                    full_scale.unwrap_or(swae::source::FULL_SCALE_HEIGHT),
                )?),
                (Generator::Swae, Some(w)) => Box::new(swae::SwaeSource::from_file(
                    &w,
                    full_scale.unwrap_or(swae::source::FULL_SCALE_HEIGHT),
                )?),
                (Generator::Interim, None) => Box::new(tasks::interim::BandedSource),
                (Generator::InterimV1, None) => Box::new(tasks::interim::SpectralSource::default()),
                (_, Some(_)) => anyhow::bail!("--weights only applies to --generator swae"),
            };
            let m = tasks::cli::generate_set_with_surface(&out, seed, source.as_ref(), surface)?;
            println!(
                "wrote {} worlds to {} (task-set version {}, generator {})",
                m.worlds.len(),
                out.display(),
                m.version,
                m.generator
            );
        }
        TasksCmd::Stats { dir, json } => {
            let s = tasks::cli::stats(&open(dir)?)?;
            if json {
                println!("{}", serde_json::to_string_pretty(&s)?);
            } else {
                print!("{}", tasks::cli::stats_text(&s));
            }
        }
        TasksCmd::Render {
            dir,
            world,
            ppm,
            out,
        } => {
            for f in tasks::cli::render_set(&open(dir)?, &world, &out, ppm)? {
                println!("{f}");
            }
        }
        TasksCmd::ImportVertiBench { path, out } => {
            let m = tasks::cli::import_release(&path, &out)?;
            println!(
                "imported {} worlds into {} (task-set version {})",
                m.worlds.len(),
                out.display(),
                m.version
            );
        }
    }
    Ok(())
}
