//! Files of an evaluation: `episodes.csv` (and `episodes.parquet`, [`crate::parquet_file`]), `summary.json`,
//! `summary.txt` and `charts.svg` ([`crate::charts`]).

use crate::summary::{named, Aggregate, Summary};
use crate::EpisodeRow;
#[cfg(feature = "parquet")]
use crate::{io_err, ResultsError};
use std::fmt::Write as _;
#[cfg(feature = "parquet")]
use std::path::Path;

/// Values of one column of the episode table.
#[derive(Clone, Debug, PartialEq)]
pub enum ColumnValues {
    Text(Vec<String>),
    Int(Vec<i64>),
    /// Floats printed in CSV with the given number of decimals.
    Float(Vec<f64>, usize),
    /// Floats that may be absent (CSV: empty field; Parquet: null).
    OptFloat(Vec<Option<f64>>, usize),
    /// Integers that may be absent (CSV: empty field; Parquet: null).
    OptInt(Vec<Option<i64>>),
}

/// One column of the episode table: the same columns go to `episodes.csv` and `episodes.parquet`.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    pub name: &'static str,
    pub values: ColumnValues,
}

/// The episode table: task factors, outcome, reason, traversal time (successes only) and every metric.
pub fn episode_columns(rows: &[EpisodeRow]) -> Vec<Column> {
    fn text(name: &'static str, rows: &[EpisodeRow], f: impl Fn(&EpisodeRow) -> String) -> Column {
        Column {
            name,
            values: ColumnValues::Text(rows.iter().map(f).collect()),
        }
    }
    fn int(name: &'static str, rows: &[EpisodeRow], f: impl Fn(&EpisodeRow) -> i64) -> Column {
        Column {
            name,
            values: ColumnValues::Int(rows.iter().map(f).collect()),
        }
    }
    fn float(
        name: &'static str,
        d: usize,
        rows: &[EpisodeRow],
        f: impl Fn(&EpisodeRow) -> f64,
    ) -> Column {
        Column {
            name,
            values: ColumnValues::Float(rows.iter().map(f).collect(), d),
        }
    }
    vec![
        text("task_id", rows, |r| r.task_id.to_string()),
        int("world_id", rows, |r| r.world_id.into()),
        int("task_index", rows, |r| r.task_index.into()),
        text("level", rows, |r| r.level.to_string()),
        text("semantics", rows, |r| r.semantics.to_string()),
        text("density", rows, |r| r.density.to_string()),
        Column {
            name: "terrain",
            values: ColumnValues::OptInt(rows.iter().map(|r| r.terrain.map(i64::from)).collect()),
        },
        text("planner", rows, |r| r.planner.to_string()),
        text("vehicle", rows, |r| r.vehicle.to_string()),
        // Full precision in CSV (`{}` of an f64 round-trips).
        Column {
            name: "scale",
            values: ColumnValues::Text(rows.iter().map(|r| r.scale.to_string()).collect()),
        },
        int("seed", rows, |r| r.seed as i64),
        text("task_set_version", rows, |r| r.task_set_version.clone()),
        text("sim_version", rows, |r| r.sim_version.to_string()),
        text("outcome", rows, |r| r.outcome.as_str().to_string()),
        text("reason", rows, |r| r.reason.to_string()),
        float("time_s", 3, rows, |r| r.metrics.time),
        Column {
            name: "traversal_time_s",
            values: ColumnValues::OptFloat(
                rows.iter()
                    .map(|r| (r.is_success()).then_some(r.metrics.time))
                    .collect(),
                3,
            ),
        },
        float("roll_mean_deg", 4, rows, |r| r.metrics.roll.mean),
        float("roll_var", 4, rows, |r| r.metrics.roll.var),
        float("roll_max", 4, rows, |r| r.metrics.roll.max),
        float("roll_abs_mean_deg", 4, rows, |r| r.metrics.roll_abs.mean),
        float("roll_abs_var", 4, rows, |r| r.metrics.roll_abs.var),
        float("roll_abs_max", 4, rows, |r| r.metrics.roll_abs.max),
        float("pitch_mean_deg", 4, rows, |r| r.metrics.pitch.mean),
        float("pitch_var", 4, rows, |r| r.metrics.pitch.var),
        float("pitch_max", 4, rows, |r| r.metrics.pitch.max),
        float("pitch_abs_mean_deg", 4, rows, |r| r.metrics.pitch_abs.mean),
        float("pitch_abs_var", 4, rows, |r| r.metrics.pitch_abs.var),
        float("pitch_abs_max", 4, rows, |r| r.metrics.pitch_abs.max),
        float("throttle_mean", 4, rows, |r| r.metrics.throttle_mean),
        float("throttle_var", 4, rows, |r| r.metrics.throttle_var),
        float("throttle_tv", 4, rows, |r| r.metrics.throttle_tv),
        float("steering_mean", 4, rows, |r| r.metrics.steering_mean),
        float("steering_var", 4, rows, |r| r.metrics.steering_var),
        float("steering_tv", 4, rows, |r| r.metrics.steering_tv),
        float("path_length_m", 3, rows, |r| r.metrics.path_length),
        float("energy_j", 1, rows, |r| r.metrics.energy),
        int("obstacle_contacts", rows, |r| {
            r.metrics.obstacle_contacts.into()
        }),
        float("final_goal_distance_m", 3, rows, |r| {
            r.metrics.final_goal_distance
        }),
        int("steps", rows, |r| r.metrics.steps as i64),
        float("wall_time_s", 4, rows, |r| r.wall_time_s),
    ]
}

/// One CSV row per episode with every metric ([`episode_columns`]; an absent traversal time is an empty field).
pub fn episodes_csv(rows: &[EpisodeRow]) -> String {
    let cols = episode_columns(rows);
    let names: Vec<&str> = cols.iter().map(|c| c.name).collect();
    let mut s = names.join(",") + "\n";
    for i in 0..rows.len() {
        for (j, c) in cols.iter().enumerate() {
            if j > 0 {
                s.push(',');
            }
            let _ = match &c.values {
                ColumnValues::Text(v) => write!(s, "{}", v[i]),
                ColumnValues::Int(v) => write!(s, "{}", v[i]),
                ColumnValues::Float(v, d) => write!(s, "{:.*}", d, v[i]),
                ColumnValues::OptFloat(v, d) => match v[i] {
                    Some(x) => write!(s, "{:.*}", d, x),
                    None => Ok(()),
                },
                ColumnValues::OptInt(v) => match v[i] {
                    Some(x) => write!(s, "{x}"),
                    None => Ok(()),
                },
            };
        }
        s.push('\n');
    }
    s
}

fn line(name: &str, a: &Aggregate) -> String {
    format!(
        "{name:<14} {:>5} {:>6.1}% [{:>5.1}, {:>5.1}] {:>6.1} {:>7.1} {:>6.2} {:>6.2} {:>6.2} {:>6.2} {:>7.1}% {:>6.1}% {:>7.1}% {:>7.1}%\n",
        a.episodes,
        100.0 * a.success_rate,
        100.0 * a.success_ci95.0,
        100.0 * a.success_ci95.1,
        a.traversal_time_mean,
        a.traversal_time_var,
        a.roll_mean,
        a.roll_var,
        a.pitch_mean,
        a.pitch_var,
        a.rollover_pct,
        a.stuck_pct,
        a.timeout_pct,
        a.off_map_pct + a.planner_failure_pct
    )
}

/// Human-readable summary table.
pub fn summary_text(s: &Summary) -> String {
    let mut t = format!(
        "planner {} | vehicle {} (scale {}) | task set {} | {} | {} rules\n",
        s.planner,
        s.vehicle,
        s.scale,
        s.task_set_version,
        s.sim_version,
        s.rules.as_str()
    );
    if !s.perception.is_ideal() {
        t.insert_str(t.len() - 1, &format!(" | perception {}", s.perception));
    }
    t += "(time: traversal time of successes, s, mean and variance; roll, pitch: per-episode mean |angle|, deg, mean and variance over episodes)\n";
    t += "group          tasks success  [95% CI]      time  time_var   roll roll_var  pitch pitch_var rollover  stuck  timeout  other\n";
    t += &line("overall", &s.overall);
    for (title, entries) in [
        ("elevation", named(&s.by_level)),
        ("semantics", named(&s.by_semantics)),
        ("obstacles", named(&s.by_density)),
    ] {
        t += &format!("-- {title}\n");
        for (k, a) in entries {
            t += &line(k, a);
        }
    }
    if s.semantics_level_adjusted.len() > 1 {
        t += "-- semantics, success standardised over elevation levels (mean of the per-level rates)\n";
        for (k, v) in &s.semantics_level_adjusted {
            t += &format!("{k:<14} {:>12.1}%\n", 100.0 * v);
        }
    }
    if !s.density_matched.is_empty() {
        t += "-- obstacle density on matched tasks (same terrain and start/goal; denser minus sparser)\n";
        for c in &s.density_matched {
            let m = &c.comparison;
            t += &format!(
                "{:<6} -> {:<6} {:>5} tasks  {:>5.1}% -> {:>5.1}%  {:>+6.1} points [{:+.1}, {:+.1}]  McNemar {}{}\n",
                c.sparser,
                c.denser,
                m.paired_tasks,
                100.0 * m.success_b,
                100.0 * m.success_a,
                100.0 * m.difference,
                100.0 * m.difference_ci95.0,
                100.0 * m.difference_ci95.1,
                crate::compare::p_text(m.mcnemar_p),
                if m.significant { " (significant)" } else { "" }
            );
        }
    }
    t
}

/// Writes every file of an evaluation into `dir`.
#[cfg(feature = "parquet")]
pub fn write(dir: &Path, rows: &[EpisodeRow], s: &Summary) -> Result<(), ResultsError> {
    let files = [
        ("episodes.csv", episodes_csv(rows)),
        (
            "summary.json",
            serde_json::to_string_pretty(s).map_err(|e| io_err(dir, e))? + "\n",
        ),
        ("summary.txt", summary_text(s)),
        ("charts.svg", crate::charts::charts_svg(s).into_string()),
    ];
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| io_err(&p, e))?;
    }
    crate::parquet_file::write_episodes(&dir.join("episodes.parquet"), rows)
}
