//! `vb dataset info`: a short text summary of a dataset.

use crate::episodes::read_episodes;
use crate::error::DatasetError;
use crate::layout::{scan, INFO};
use crate::meta::read_info;
use contracts::Outcome;
use std::path::Path;

/// A short text summary of a dataset: what it is, counts, simulated hours and the outcome mix.
pub fn info(dir: &Path) -> Result<String, DatasetError> {
    let i = read_info(&dir.join(INFO))?;
    let spec = &i.vertibench.spec;
    let s = scan(dir)?;
    let mut outcomes = std::collections::BTreeMap::<Outcome, u64>::new();
    for id in &s.episodes {
        for r in read_episodes(&dir.join(id.episodes()), spec)? {
            *outcomes.entry(r.meta.outcome).or_default() += 1;
        }
    }
    let total: u64 = outcomes.values().sum();
    let mix: Vec<String> = outcomes
        .iter()
        .map(|(o, n)| format!("{o} {n} ({:.0}%)", 100.0 * *n as f64 / total.max(1) as f64))
        .collect();
    let kind = serde_json::to_value(spec.kind)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default();
    let variant = serde_json::to_value(spec.variant)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default();
    Ok(format!(
        "{}: vertibench {kind} dataset ({variant}), {}\nvehicle {} at scale {}, {} fps, simulator {}, task set {}\n\
         {} episodes, {} frames, {:.2} simulated hours, {} data files, {} tasks\noutcomes: {}\n",
        dir.display(),
        if i.vertibench.complete { "complete" } else { "incomplete" },
        spec.vehicle,
        spec.scale,
        spec.control_rate_hz,
        spec.sim_version,
        spec.task_set_version,
        i.total_episodes,
        i.total_frames,
        i.vertibench.totals.simulated_hours,
        s.data.len(),
        i.total_tasks,
        if mix.is_empty() { "none".to_string() } else { mix.join(", ") }
    ))
}
