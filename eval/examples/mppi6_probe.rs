//! Measures MPPI-6's cost and results on a sample of tasks for a choice of parameters (how the defaults in
//! `baselines::mppi6` were chosen; figures in BENCHMARKS.md).
//!
//! `cargo run --release -p eval --example mppi6_probe -- [SAMPLES] [HORIZON_S] [REPLAN_EVERY] [EVERY_NTH_WORLD]`
//! runs task `w % 10` of every `EVERY_NTH_WORLD`-th world (default 2: 50 tasks) with the full-scale HMMWV, in
//! parallel, and prints outcomes, wall time, decisions and CPU time per decision. The bicycle MPPI runs on the
//! same tasks for reference when the first argument is `mppi`.

use rayon::prelude::*;
use sim_core::episode::EpisodeConfig;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, d: f64| args.get(i).and_then(|s| s.parse().ok()).unwrap_or(d);
    let bicycle = args.first().is_some_and(|s| s == "mppi");
    let d = baselines::mppi6::Mppi6Config::default();
    let cfg = baselines::mppi6::Mppi6Config {
        samples: arg(0, d.samples as f64) as usize,
        horizon: arg(1, d.horizon),
        replan_every: arg(2, d.replan_every as f64) as usize,
        ..d
    };
    let nth = arg(3, 2.0) as u32;
    let set = tasks::TaskSet::committed()?;
    let vehicle = sim_core::vehicle::vehicle_by_name("hmmwv")?;
    let todo: Vec<u32> = set
        .world_ids()
        .into_iter()
        .filter(|w| w % nth.max(1) == 0)
        .collect();
    let t0 = Instant::now();
    let rows: Vec<(String, String, f64, u64, u64, f64)> = todo
        .par_iter()
        .map(|&w| {
            let world = set.world(w, 1.0).expect("world");
            let task = set.tasks(w, 1.0).expect("tasks")[(w % 10) as usize].clone();
            let t = Instant::now();
            let ep = EpisodeConfig::default();
            let (r, dec, steps) = if bicycle {
                let mut p = baselines::mppi::Mppi::new();
                (
                    sim_core::run_episode(&world, &task, &vehicle, &mut p, &ep),
                    0,
                    0,
                )
            } else {
                let mut p = baselines::mppi6::Mppi6::with_config(cfg);
                let r = sim_core::run_episode(&world, &task, &vehicle, &mut p, &ep);
                (r, p.decisions, p.rollout_steps)
            };
            (
                world.level.as_str().to_string(),
                r.outcome.as_str().to_string(),
                r.metrics.time,
                dec,
                steps,
                t.elapsed().as_secs_f64(),
            )
        })
        .collect();
    let wall = t0.elapsed().as_secs_f64();
    let n = rows.len() as f64;
    let count = |o: &str| rows.iter().filter(|r| r.1 == o).count();
    let cpu: f64 = rows.iter().map(|r| r.5).sum();
    let dec: u64 = rows.iter().map(|r| r.3).sum();
    let steps: u64 = rows.iter().map(|r| r.4).sum();
    let sim: f64 = rows.iter().map(|r| r.2).sum();
    println!(
        "{} K={} H={} replan_every={}: {} tasks, wall {wall:.1} s, CPU {cpu:.1} s ({:.2} s/episode, {:.1} ms/decision, {:.0} rollout steps/decision, {:.1} s simulated/episode)",
        if bicycle { "mppi" } else { "mppi6" },
        cfg.samples,
        cfg.horizon,
        cfg.replan_every,
        rows.len(),
        cpu / n,
        1000.0 * cpu / dec.max(1) as f64,
        steps as f64 / dec.max(1) as f64,
        sim / n,
    );
    println!(
        "success {} rollover {} stuck {} timeout {} other {}",
        count("success"),
        count("rollover"),
        count("stuck"),
        count("timeout"),
        rows.len() - count("success") - count("rollover") - count("stuck") - count("timeout")
    );
    for level in ["low", "medium", "high"] {
        let l: Vec<_> = rows.iter().filter(|r| r.0 == level).collect();
        let c = |o: &str| l.iter().filter(|r| r.1 == o).count();
        println!(
            "  {level}: {} tasks, success {} rollover {} stuck {}",
            l.len(),
            c("success"),
            c("rollover"),
            c("stuck")
        );
    }
    Ok(())
}
