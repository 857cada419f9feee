//! Throughput of the dataset generators (release build):
//!
//! ```text
//! cargo run --release -p datasets --example generate_bench -- TASK_DIR KIND HOURS [THREADS] [lite|full] [PLANNER]
//! ```
//!
//! Runs `KIND` (`random`, `expert`, `failures`) for `HOURS` kept hours into a sink that only counts, and prints
//! the kept and simulated hours, the wall and CPU time, and simulated hours per core-hour (CPU time of this
//! process, so other load on the machine does not count against it).

use anyhow::{bail, Context, Result};
use datasets::generate::{
    failures_spec, run, spec, EpisodeSink, GenerateConfig, Resume, SinkError,
};
use datasets::{DatasetKind, DatasetWriter, RecordedEpisode, Variant};
use std::time::Instant;

#[derive(Default)]
struct Count {
    episodes: u64,
    frames: u64,
    /// Episodes by (level, semantics, outcome).
    by: std::collections::BTreeMap<String, u64>,
}

impl EpisodeSink for Count {
    fn append(&mut self, rec: &RecordedEpisode) -> Result<(), SinkError> {
        self.episodes += 1;
        self.frames += rec.frames.len() as u64;
        let m = &rec.meta;
        *self
            .by
            .entry(format!("{} {} {}", m.level, m.semantics, m.outcome))
            .or_default() += 1;
        Ok(())
    }
}

/// User plus system CPU seconds of this process (Linux).
fn cpu_seconds() -> Result<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat")?;
    let after = stat.rsplit_once(')').context("/proc/self/stat")?.1;
    let f: Vec<&str> = after.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>()? + f[12].parse::<f64>()?;
    Ok(ticks / 100.0)
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        bail!("usage: generate_bench TASK_DIR KIND HOURS [THREADS] [lite|full] [PLANNER]");
    }
    let kind = match args[1].as_str() {
        "random" => DatasetKind::Random,
        "expert" => DatasetKind::Expert,
        "failures" => DatasetKind::Failures,
        k => bail!("kind `{k}`"),
    };
    let mut cfg = GenerateConfig::new(kind, &args[0], args[2].parse()?);
    cfg.threads = args.get(3).map_or(Ok(0), |t| t.parse())?;
    if args.get(4).map(String::as_str) == Some("full") {
        cfg.variant = Variant::Full;
    }
    if let Some(p) = args.get(5) {
        cfg.planners = p.split(',').map(str::to_string).collect();
    }
    let (mut main, mut failures) = (Count::default(), Count::default());
    let (t0, c0) = (Instant::now(), cpu_seconds()?);
    // With VB_BENCH_OUT=DIR the episodes go through the LeRobot v3 writer into DIR/main and DIR/failures.
    let s = match std::env::var_os("VB_BENCH_OUT") {
        None => {
            let feed: Option<&mut dyn EpisodeSink> =
                (kind != DatasetKind::Failures).then_some(&mut failures as _);
            run(&cfg, &Resume::default(), &mut main, feed, &|_| {})?
        }
        Some(out) => {
            let out = std::path::Path::new(&out);
            let mut m = DatasetWriter::open(&out.join("main"), &spec(&cfg)?, "generate_bench")?;
            let mut f = DatasetWriter::open(
                &out.join("failures"),
                &failures_spec(&cfg)?,
                "generate_bench",
            )?;
            let feed: Option<&mut dyn EpisodeSink> =
                (kind != DatasetKind::Failures).then_some(&mut f as _);
            let s = run(&cfg, &Resume::default(), &mut m, feed, &|_| {})?;
            main.episodes = m.finish()?.episodes;
            failures.episodes = f.finish()?.episodes;
            s
        }
    };
    let (wall, cpu) = (t0.elapsed().as_secs_f64(), cpu_seconds()? - c0);
    let kept_h = s.kept_seconds / 3600.0;
    let sim_h = s.simulated_seconds / 3600.0;
    println!(
        "{} {:?} threads={} planners={:?}: {} episodes run, {} kept ({:.3} h), {} failure windows; simulated {:.3} h",
        args[1], cfg.variant, cfg.threads, cfg.planners, s.episodes_run, main.episodes, kept_h,
        failures.episodes, sim_h
    );
    println!("outcomes {:?}, windows {:?}", s.outcomes, s.windows);
    if std::env::var_os("VB_BENCH_DETAIL").is_some() {
        println!("kept by level, semantics, outcome: {:#?}", main.by);
    }
    println!(
        "wall {wall:.1} s, cpu {cpu:.1} s; kept h per core-hour {:.1}, simulated h per core-hour {:.1}, kept h per \
         wall hour {:.1}",
        kept_h / (cpu / 3600.0),
        sim_h / (cpu / 3600.0),
        kept_h / (wall / 3600.0)
    );
    Ok(())
}
