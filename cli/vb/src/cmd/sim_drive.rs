//! `vb sim drive` (a built-in planner driving a vehicle simulated elsewhere, judged by the benchmark's rules) and
//! `vb sim episodes` (those episodes beside sim-core's): issue 59 item 4, with the Chrono harness's `episodes`.

use anyhow::Context;
use contracts::TaskId;
use sim_core::episode::EpisodeConfig;
use std::path::Path;

pub fn drive(
    task_dir: &Path,
    id: TaskId,
    planner: &str,
    vehicle: &str,
    release_rules: bool,
) -> anyhow::Result<()> {
    let spec = sim_core::vehicle::vehicle_by_name(vehicle)?;
    let set = tasks::TaskSet::load(task_dir)?;
    let world = set.world(id.world, spec.scale)?;
    let task = set
        .tasks(id.world, spec.scale)?
        .into_iter()
        .find(|t| t.index == id.index)
        .with_context(|| format!("task {id} is not in {}", task_dir.display()))?;
    let mut planner = eval::Builtin::resolve(planner, None)?.make();
    let cfg = if release_rules {
        EpisodeConfig::release()
    } else {
        EpisodeConfig::default()
    };
    let stdin = std::io::stdin().lock();
    let stdout = std::io::stdout().lock();
    eval::external::drive(stdin, stdout, &world, &task, &spec, planner.as_mut(), &cfg)
        .with_context(|| format!("driving {id}"))?;
    Ok(())
}

pub fn episodes(
    task_dir: &Path,
    reference: &Path,
    vehicle: &str,
    json: bool,
) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(reference)
        .with_context(|| format!("reading the reference {}", reference.display()))?;
    let r = eval::beside::reference_episodes(&text)
        .with_context(|| format!("the reference {}", reference.display()))?
        .with_context(|| {
            format!(
                "the reference {} holds no episodes (the harness's `episodes --out`)",
                reference.display()
            )
        })?;
    let spec = sim_core::vehicle::vehicle_by_name(vehicle)?;
    let set = tasks::TaskSet::load(task_dir)?;
    let pairs = eval::beside::run_beside(&set, &spec, &r)?;
    if json {
        println!("{}", serde_json::to_string_pretty(&pairs)?);
    } else {
        println!(
            "{} driving {} tasks under the {} rules, sim-core beside {}:",
            r.driver.planner,
            pairs.len(),
            r.driver.config.rules(),
            r.simulator
        );
        print!("{}", eval::beside::pairs_table(&pairs, &r.simulator));
    }
    Ok(())
}
