//! `vb sim characterize`: a vehicle's datasheet, the move-off check on a task set, and both beside a reference's.

use anyhow::Context;
use eval::move_off::{Agreement, MoveOff, StartDistance};
use eval::reference::Comparison;
use sim_core::characterize::{datasheet, Datasheet, Ground, Setup};
use std::path::{Path, PathBuf};

/// What the command was asked for.
pub struct Args {
    pub vehicle: String,
    pub surface: String,
    pub dt: Option<f64>,
    pub json: bool,
    pub task_dir: Option<PathBuf>,
    pub reference: Option<PathBuf>,
}

/// A reference file, read and checked before minutes of simulation.
struct Reference {
    path: PathBuf,
    text: String,
    move_off: Option<Vec<StartDistance>>,
}

fn read_reference(path: PathBuf, task_dir: Option<&Path>) -> anyhow::Result<Reference> {
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("reading the reference {}", path.display()))?;
    let named = || format!("the reference {}", path.display());
    eval::reference::compare(&[], &text).with_context(named)?;
    let move_off = eval::reference::move_off(&text).with_context(named)?;
    anyhow::ensure!(
        move_off.is_none() || task_dir.is_some(),
        "the reference {} holds the move-off check start by start: give --task-dir with the task set it ran on",
        path.display()
    );
    Ok(Reference {
        path,
        text,
        move_off,
    })
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let reference = a
        .reference
        .map(|p| read_reference(p, a.task_dir.as_deref()))
        .transpose()?;
    let spec = sim_core::vehicle::vehicle_by_name(&a.vehicle)?;
    super::sim::check_dt(a.dt)?;
    let grounds: Vec<Ground> = if a.surface == "all" {
        Ground::ALL.to_vec()
    } else {
        vec![Ground::from_name(&a.surface).ok_or_else(|| {
            anyhow::anyhow!(
                "unknown --surface `{}` (rigid, snow, mud, sand or all)",
                a.surface
            )
        })?]
    };
    let sheets: Vec<Datasheet> = grounds
        .into_iter()
        .map(|ground| datasheet(&spec, &Setup { ground, dt: a.dt }))
        .collect();
    let move_off = match &a.task_dir {
        Some(dir) => Some(eval::move_off::move_off(
            &tasks::TaskSet::load(dir)?,
            &spec,
            a.dt,
        )?),
        None => None,
    };
    let comparison = match &reference {
        Some(r) => {
            let ours = sheets
                .iter()
                .map(serde_json::to_value)
                .collect::<Result<Vec<_>, _>>()?;
            Some(
                eval::reference::compare(&ours, &r.text)
                    .with_context(|| format!("the reference {}", r.path.display()))?,
            )
        }
        None => None,
    };
    let agreement = match (
        &move_off,
        reference.as_ref().and_then(|r| r.move_off.as_ref()),
    ) {
        (Some(ours), Some(theirs)) => Some(eval::move_off::agreement(ours, theirs)),
        _ => None,
    };
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "datasheets": sheets,
                "move_off": move_off,
                "comparison": comparison,
                "move_off_agreement": agreement
            }))?
        );
        return Ok(());
    }
    print!("{}", sim_core::characterize::table(&sheets));
    if let (Some(m), Some(dir)) = (&move_off, &a.task_dir) {
        print_move_off(m, dir);
    }
    if let Some(r) = &reference {
        print_beside(&r.path, comparison, agreement.as_ref());
    }
    Ok(())
}

fn print_move_off(m: &MoveOff, dir: &Path) {
    let stuck = m.stuck();
    println!(
        "move-off from the {} starts of {}: stuck (under 5 m in 20 s at full throttle towards the goal) at {} ({:.1}%){}{}",
        m.starts(),
        dir.display(),
        stuck.len(),
        100.0 * m.stuck_share(),
        if stuck.is_empty() { "" } else { ": " },
        stuck
            .iter()
            .map(|t| t.to_string())
            .collect::<Vec<_>>()
            .join(" ")
    );
}

fn print_beside(path: &Path, comparison: Option<Vec<Comparison>>, agreement: Option<&Agreement>) {
    // (A reference of move-off starts only has no datasheet to compare.)
    if let Some(rows) = comparison.filter(|r| r.iter().any(|c| c.reference.is_some())) {
        println!("beside the reference {}:", path.display());
        print!("{}", eval::reference::table(&rows));
    }
    if let Some(a) = agreement {
        println!(
            "move-off start by start beside the reference {} (moved: at least 5 m in 20 s):",
            path.display()
        );
        print!("{}", eval::move_off::agreement_table(a));
    }
}
