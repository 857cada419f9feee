//! `vb bench move-off`: the HMMWV's move-off check from every start of some worlds, timed on one thread, beside the
//! Chrono harness's wall time for the same starts (issue 59, item 2: "N times faster than Chrono", same scenarios,
//! one machine).

use anyhow::Context;
use contracts::TaskId;
use std::path::Path;
use std::time::Instant;

/// The harness's `move_off` object: its starts and their wall time in all.
struct ReferenceRun {
    tasks: Vec<TaskId>,
    wall_s: f64,
    simulator: String,
}

fn reference_run(text: &str) -> anyhow::Result<ReferenceRun> {
    let v: serde_json::Value = serde_json::from_str(text)?;
    let tasks = eval::reference::move_off(text)?
        .context("it holds no move_off check (the harness's `move-off --out`)")?
        .into_iter()
        .map(|s| s.task)
        .collect();
    let wall_s = v["move_off"]["wall_s"]
        .as_f64()
        .filter(|w| w.is_finite() && *w > 0.0)
        .context("its move_off has no positive wall_s")?;
    let simulator = v["reference"]["simulator"]
        .as_str()
        .unwrap_or("the reference")
        .to_string();
    Ok(ReferenceRun {
        tasks,
        wall_s,
        simulator,
    })
}

pub fn run(task_dir: &Path, worlds: Option<&str>, reference: Option<&Path>) -> anyhow::Result<()> {
    let set = tasks::TaskSet::load(task_dir)?;
    let ids: Vec<u32> = match worlds {
        Some(list) => list
            .split(',')
            .map(|w| {
                w.trim()
                    .parse::<u32>()
                    .with_context(|| format!("--worlds: `{w}` is not a world id"))
            })
            .collect::<anyhow::Result<_>>()?,
        None => {
            let (rigid, soft) = super::bench::first_rigid_and_deformable(&set)?;
            vec![rigid, soft]
        }
    };
    let reference = reference
        .map(|p| {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("reading the reference {}", p.display()))?;
            reference_run(&text).with_context(|| format!("the reference {}", p.display()))
        })
        .transpose()?;
    let spec = sim_core::vehicle::vehicle_by_name("hmmwv")?;
    let mut ran = Vec::new();
    let mut wall = 0.0;
    println!("task       ground       distance m   wall s");
    for id in ids {
        let world = set.world(id, spec.scale)?;
        let ground = set.world_meta(id).map_or("?", |m| m.semantics.as_str());
        for task in set.tasks(id, spec.scale)? {
            let t0 = Instant::now();
            let d = sim_core::move_off::move_off_distance(&world, &task, &spec, None);
            let w = t0.elapsed().as_secs_f64();
            wall += w;
            let tid = TaskId::new(task.world_id, task.index);
            println!(
                "{:<10} {:<12} {:>10.1} {:>8.3}",
                tid.to_string(),
                ground,
                d,
                w
            );
            ran.push(tid);
        }
    }
    let starts = ran.len();
    anyhow::ensure!(starts > 0, "the chosen worlds have no tasks");
    let driven = starts as f64 * sim_core::move_off::MOVE_OFF_TIME;
    println!(
        "{}: {starts} starts in {wall:.2} s, {:.3} s a start, {:.0} s driven per wall-clock second",
        sim_core::SIM_VERSION,
        wall / starts as f64,
        driven / wall
    );
    if let Some(mut r) = reference {
        r.tasks.sort();
        ran.sort();
        anyhow::ensure!(
            r.tasks == ran,
            "the reference ran other starts ({} of them) than these {starts}: run it with the same --task-dir and --worlds",
            r.tasks.len()
        );
        println!(
            "{}: {starts} starts in {:.1} s, {:.3} s a start, {:.1} s driven per wall-clock second: sim-core is {:.0} times faster",
            r.simulator,
            r.wall_s,
            r.wall_s / starts as f64,
            driven / r.wall_s,
            r.wall_s / wall
        );
    }
    Ok(())
}
