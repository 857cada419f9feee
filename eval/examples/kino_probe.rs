//! Runs MPPI-6 over a learned kinodynamic model (`mppi6`, `tal`: either weights layout; or a traversability
//! estimator's file, `tnt`, over the compiled-in `tal` model) on tasks of a **training** task set for a choice of
//! the uncertainty weight: how the hybrids' planner parameters are looked at without touching the benchmark's tasks.
//!
//! `cargo run --release -p eval --example kino_probe -- WEIGHTS TASK_DIR [UNCERTAINTY] [EVERY_NTH_WORLD]` runs task
//! `w % 10` of every `EVERY_NTH_WORLD`-th world (default 4) with the full-scale HMMWV, in parallel, and prints each
//! task's outcome (`w004-t4 success`, for pairing two models' runs), the counts, the wall time and the model
//! predictions per decision.

use anyhow::Context;
use learned::kino::{KinoMppi, KinoMppiConfig};
use learned::LearnedNet;
use rayon::prelude::*;
use sim_core::episode::{EpisodeConfig, Outcome};
use std::path::Path;
use std::time::Instant;

/// One probe episode.
struct Row {
    task: String,
    outcome: Outcome,
    decisions: u64,
    predictions: u64,
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(weights), Some(dir)) = (args.first(), args.get(1)) else {
        anyhow::bail!("usage: kino_probe WEIGHTS TASK_DIR [UNCERTAINTY] [EVERY_NTH_WORLD]");
    };
    let arg = |i: usize, d: f64| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let (model, estimator) = match learned::builtin::load(Path::new(weights))? {
        LearnedNet::Kino(m) => (m, None),
        LearnedNet::Traversability(m, t) => (m, Some(*t)),
        LearnedNet::Policy(_) => anyhow::bail!("{weights} is a policy, not a kinodynamic model"),
    };
    let cfg = KinoMppiConfig {
        uncertainty: arg(2, KinoMppiConfig::default().uncertainty),
        ..KinoMppiConfig::default()
    };
    let nth = arg(3, 4.0) as u32;
    let set = tasks::TaskSet::load(Path::new(dir)).context("the task set")?;
    let vehicle = sim_core::vehicle::vehicle_by_name("hmmwv")?;
    let todo: Vec<u32> = set
        .world_ids()
        .into_iter()
        .filter(|w| w % nth.max(1) == 0)
        .collect();
    let t0 = Instant::now();
    let rows: Vec<Row> = todo
        .par_iter()
        .map(|&w| {
            let world = set.world(w, 1.0).expect("world");
            let task = set.tasks(w, 1.0).expect("tasks")[(w % 10) as usize].clone();
            let mut p = KinoMppi::new("probe", model.clone(), cfg);
            if let Some(t) = &estimator {
                p = p.with_traversability(t.clone());
            }
            let r =
                sim_core::run_episode(&world, &task, &vehicle, &mut p, &EpisodeConfig::default());
            Row {
                task: task.id(),
                outcome: r.outcome,
                decisions: p.decisions,
                predictions: p.predictions,
            }
        })
        .collect();
    for r in &rows {
        println!("{} {}", r.task, r.outcome.as_str());
    }
    let count = |o: Outcome| rows.iter().filter(|r| r.outcome == o).count();
    let dec: u64 = rows.iter().map(|r| r.decisions).sum();
    let pred: u64 = rows.iter().map(|r| r.predictions).sum();
    println!(
        "uncertainty {}: {} tasks, wall {:.1} s, {:.0} predictions/decision; success {} stuck {} rollover {} timeout {}",
        cfg.uncertainty,
        rows.len(),
        t0.elapsed().as_secs_f64(),
        pred as f64 / dec.max(1) as f64,
        count(Outcome::Success),
        count(Outcome::Stuck),
        count(Outcome::Rollover),
        count(Outcome::Timeout),
    );
    Ok(())
}
