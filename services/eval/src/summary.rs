//! Aggregates of an evaluation: overall and per factor level.

use crate::EpisodeRow;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// 95% Wilson score interval of a proportion.
pub fn wilson(successes: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let (z, n) = (1.959_963_984_540_054, n as f64);
    let p = successes as f64 / n;
    let centre = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let half = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// One aggregate cell.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Aggregate {
    pub episodes: usize,
    pub success_rate: f64,
    pub success_ci95: (f64, f64),
    /// Mean and variance of the traversal time of successful episodes, s.
    pub traversal_time_mean: f64,
    pub traversal_time_var: f64,
    /// Mean and variance (over episodes) of the per-episode mean |roll| and |pitch|, degrees.
    pub roll_mean: f64,
    pub roll_var: f64,
    pub pitch_mean: f64,
    pub pitch_var: f64,
    /// Share of each outcome, percent.
    pub rollover_pct: f64,
    pub stuck_pct: f64,
    pub timeout_pct: f64,
    pub off_map_pct: f64,
    pub planner_failure_pct: f64,
}

fn mean_var(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0);
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (
        m,
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64,
    )
}

/// Aggregates a set of rows.
pub fn aggregate<'a>(rows: impl IntoIterator<Item = &'a EpisodeRow>) -> Aggregate {
    let rows: Vec<&EpisodeRow> = rows.into_iter().collect();
    let n = rows.len();
    let pct =
        |o: &str| 100.0 * rows.iter().filter(|r| r.outcome == o).count() as f64 / n.max(1) as f64;
    let succ: Vec<&&EpisodeRow> = rows.iter().filter(|r| r.outcome == "success").collect();
    let (tm, tv) = mean_var(&succ.iter().map(|r| r.metrics.time).collect::<Vec<_>>());
    let (rm, rv) = mean_var(
        &rows
            .iter()
            .map(|r| r.metrics.roll_abs.mean)
            .collect::<Vec<_>>(),
    );
    let (pm, pv) = mean_var(
        &rows
            .iter()
            .map(|r| r.metrics.pitch_abs.mean)
            .collect::<Vec<_>>(),
    );
    Aggregate {
        episodes: n,
        success_rate: succ.len() as f64 / n.max(1) as f64,
        success_ci95: wilson(succ.len(), n),
        traversal_time_mean: tm,
        traversal_time_var: tv,
        roll_mean: rm,
        roll_var: rv,
        pitch_mean: pm,
        pitch_var: pv,
        rollover_pct: pct("rollover"),
        stuck_pct: pct("stuck"),
        timeout_pct: pct("timeout"),
        off_map_pct: pct("off_map"),
        planner_failure_pct: pct("planner_failure"),
    }
}

/// The whole summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub planner: String,
    pub vehicle: String,
    pub scale: f64,
    pub task_set_version: String,
    pub sim_version: String,
    pub overall: Aggregate,
    pub by_level: BTreeMap<String, Aggregate>,
    pub by_semantics: BTreeMap<String, Aggregate>,
    pub by_density: BTreeMap<String, Aggregate>,
    /// Sum of per-episode wall times (CPU time spent in episodes), s.
    pub episode_cpu_s: f64,
}

/// Summarises the rows of one evaluation.
pub fn summarise(rows: &[EpisodeRow]) -> Summary {
    let by = |key: fn(&EpisodeRow) -> &str| {
        let mut keys: Vec<&str> = rows.iter().map(key).collect();
        keys.sort_unstable();
        keys.dedup();
        keys.into_iter()
            .map(|k| {
                (
                    k.to_string(),
                    aggregate(rows.iter().filter(|r| key(r) == k)),
                )
            })
            .collect()
    };
    let first = rows.first();
    Summary {
        planner: first.map(|r| r.planner.clone()).unwrap_or_default(),
        vehicle: first.map(|r| r.vehicle.clone()).unwrap_or_default(),
        scale: first.map_or(1.0, |r| r.scale),
        task_set_version: first
            .map(|r| r.task_set_version.clone())
            .unwrap_or_default(),
        sim_version: first.map(|r| r.sim_version.clone()).unwrap_or_default(),
        overall: aggregate(rows),
        by_level: by(|r| &r.level),
        by_semantics: by(|r| &r.semantics),
        by_density: by(|r| &r.density),
        episode_cpu_s: rows.iter().map(|r| r.wall_time_s).sum(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_interval_matches_reference_values() {
        // 50 / 100: (0.4038, 0.5962); 0 / 10: (0, 0.2775) (standard tables).
        let (lo, hi) = wilson(50, 100);
        assert!(
            (lo - 0.4038).abs() < 1e-4 && (hi - 0.5962).abs() < 1e-4,
            "{lo} {hi}"
        );
        let (lo, hi) = wilson(0, 10);
        assert!(lo == 0.0 && (hi - 0.2775).abs() < 1e-4, "{hi}");
    }

    #[test]
    fn aggregates_count_outcomes_and_time_successes_only() {
        let row = |outcome: &str, time: f64, level: &str| EpisodeRow {
            task_id: format!("w001-t{time}"),
            world_id: 1,
            task_index: 0,
            level: level.into(),
            semantics: "rigid".into(),
            density: "sparse".into(),
            planner: "pid".into(),
            vehicle: "hmmwv".into(),
            scale: 1.0,
            seed: 0,
            task_set_version: "v".into(),
            sim_version: "s".into(),
            outcome: outcome.into(),
            reason: outcome.into(),
            detail: String::new(),
            metrics: sim_core::episode::EpisodeMetrics {
                time,
                ..Default::default()
            },
            wall_time_s: 0.1,
        };
        let rows = vec![
            row("success", 20.0, "low"),
            row("success", 30.0, "low"),
            row("stuck", 40.0, "high"),
            row("rollover", 5.0, "high"),
        ];
        let s = summarise(&rows);
        assert_eq!(s.overall.success_rate, 0.5);
        assert_eq!(s.overall.traversal_time_mean, 25.0);
        assert_eq!(s.overall.stuck_pct, 25.0);
        assert_eq!(s.by_level["low"].success_rate, 1.0);
        assert_eq!(s.by_level["high"].rollover_pct, 50.0);
    }
}
