//! Aggregates of an evaluation: overall and per factor level.

use crate::compare::{paired, Comparison};
use crate::EpisodeRow;
use contracts::{ElevationLevel, ObstacleDensity, Outcome, RecordedOutcome, SemanticsKind};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

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
    /// Episodes their caller stopped (absent from files when none was: summaries before it had no such field).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub cancelled_pct: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
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
    let pct = |o: Outcome| {
        100.0
            * rows
                .iter()
                .filter(|r| r.outcome == RecordedOutcome::Episode(o))
                .count() as f64
            / n.max(1) as f64
    };
    let succ: Vec<&&EpisodeRow> = rows.iter().filter(|r| r.is_success()).collect();
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
        rollover_pct: pct(Outcome::Rollover),
        stuck_pct: pct(Outcome::Stuck),
        timeout_pct: pct(Outcome::Timeout),
        off_map_pct: pct(Outcome::OffMap),
        planner_failure_pct: pct(Outcome::PlannerFailure),
        cancelled_pct: pct(Outcome::Cancelled),
    }
}

/// Success at a denser obstacle layout against a sparser one on the same terrain and the same start/goal pair
/// (worlds of one terrain group, the task set's design): `comparison` is denser minus sparser, so a negative
/// difference is the success the added obstacles cost, with the exact McNemar test on the discordant tasks.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct DensityContrast {
    pub sparser: String,
    pub denser: String,
    pub comparison: Comparison,
}

/// Per semantics kind, the mean over the levels of the evaluation of its per-level success rate (a kind missing at
/// some level of the evaluation is left out).
pub fn semantics_level_adjusted(rows: &[EpisodeRow]) -> BTreeMap<SemanticsKind, f64> {
    let mut cells: BTreeMap<(SemanticsKind, ElevationLevel), (usize, usize)> = BTreeMap::new();
    for r in rows {
        let c = cells.entry((r.semantics, r.level)).or_default();
        c.0 += usize::from(r.is_success());
        c.1 += 1;
    }
    // The levels' rates are summed in their names' order (as the summaries always have been, to the last bit).
    let mut levels: Vec<ElevationLevel> = rows
        .iter()
        .map(|r| r.level)
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    levels.sort_by_key(|l| l.as_str());
    let kinds: BTreeSet<SemanticsKind> = rows.iter().map(|r| r.semantics).collect();
    kinds
        .into_iter()
        .filter_map(|k| {
            let rates: Option<Vec<f64>> = levels
                .iter()
                .map(|l| cells.get(&(k, *l)).map(|&(s, n)| s as f64 / n as f64))
                .collect();
            rates.map(|r| (k, r.iter().sum::<f64>() / r.len() as f64))
        })
        .collect()
}

/// The three density contrasts (sparse-medium, medium-dense, sparse-dense) of the rows that carry a terrain
/// group; pairs are (terrain group, task index). Empty when no task is present at two densities.
pub fn density_matched(rows: &[EpisodeRow]) -> Vec<DensityContrast> {
    let mut by: BTreeMap<(u32, u32, &str), bool> = BTreeMap::new();
    for r in rows {
        if let Some(t) = r.terrain {
            by.insert((t, r.task_index, r.density.as_str()), r.is_success());
        }
    }
    [
        ("sparse", "medium"),
        ("medium", "dense"),
        ("sparse", "dense"),
    ]
    .into_iter()
    .filter_map(|(sparser, denser)| {
        let pairs: Vec<(bool, bool)> = by
            .iter()
            .filter(|((_, _, d), _)| *d == denser)
            .filter_map(|(&(t, k, _), &ok)| by.get(&(t, k, sparser)).map(|&s| (ok, s)))
            .collect();
        (!pairs.is_empty()).then(|| DensityContrast {
            sparser: sparser.into(),
            denser: denser.into(),
            comparison: paired(pairs),
        })
    })
    .collect()
}

/// The whole summary.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    pub planner: contracts::PlannerName,
    pub vehicle: contracts::VehicleId,
    pub scale: f64,
    pub task_set_version: String,
    pub sim_version: contracts::SimVersion,
    /// The episode rules the rows followed (older summaries without it: the paper's).
    #[serde(default)]
    pub rules: contracts::Rules,
    /// The perception profile (omitted for ground truth, `ideal`).
    #[serde(default, skip_serializing_if = "contracts::PerceptionId::is_ideal")]
    pub perception: contracts::PerceptionId,
    pub overall: Aggregate,
    /// Each breakdown is keyed by the vocabulary's values, in their canonical order (low, medium, high; rigid,
    /// deformable, mixed; sparse, medium, dense).
    pub by_level: BTreeMap<ElevationLevel, Aggregate>,
    pub by_semantics: BTreeMap<SemanticsKind, Aggregate>,
    pub by_density: BTreeMap<ObstacleDensity, Aggregate>,
    /// Success rate of each semantics kind standardised over elevation levels: the mean of its per-level success
    /// rates over the levels present in the evaluation. The 100 worlds cannot balance semantics within every level
    /// (each level has 11 terrain triples, split 4 / 4 / 3 between the kinds), and level dominates success, so raw
    /// per-kind rates carry the design's imbalance; these do not.
    #[serde(default)]
    pub semantics_level_adjusted: BTreeMap<SemanticsKind, f64>,
    /// Density contrasts on matched tasks: the same terrain group and start/goal pair at two densities.
    #[serde(default)]
    pub density_matched: Vec<DensityContrast>,
    /// Sum of the episodes' wall times, s (each episode runs on one thread: on an idle machine this is close to
    /// the CPU time spent in episodes, on a loaded one it is more). Read from older files as `episode_cpu_s`.
    #[serde(alias = "episode_cpu_s")]
    pub episode_wall_s: f64,
}

/// A factor of the task set whose values key a summary's breakdowns.
pub trait Factor: Copy + Ord + 'static {
    /// Every value, in the canonical order.
    const ALL: &'static [Self];
    /// The value's one string form.
    fn name(self) -> &'static str;
}

macro_rules! factor {
    ($($t:ty),+) => {$(
        impl Factor for $t {
            const ALL: &'static [$t] = <$t>::ALL;
            fn name(self) -> &'static str {
                self.as_str()
            }
        }
    )+};
}
factor!(ElevationLevel, SemanticsKind, ObstacleDensity);

/// A breakdown's entries by name, in the factor's canonical order.
pub fn named<K: Factor, V>(map: &BTreeMap<K, V>) -> Vec<(&'static str, &V)> {
    map.iter().map(|(k, v)| (k.name(), v)).collect()
}

/// The aggregate of the rows of each value of `key` that occurs.
fn breakdown<K: Ord + Copy>(
    rows: &[EpisodeRow],
    key: fn(&EpisodeRow) -> K,
) -> BTreeMap<K, Aggregate> {
    let keys: BTreeSet<K> = rows.iter().map(key).collect();
    keys.into_iter()
        .map(|k| (k, aggregate(rows.iter().filter(|r| key(r) == k))))
        .collect()
}

/// Summarises the rows of one evaluation, in task order whatever order they come in (a service gets them in the
/// order they finished), so the sums, and the summary, are the same to the last bit as a local `vb eval`'s.
pub fn summarise(rows: &[EpisodeRow]) -> Summary {
    let ordered = |a: &EpisodeRow, b: &EpisodeRow| {
        (a.world_id, a.task_index, &a.task_id).cmp(&(b.world_id, b.task_index, &b.task_id))
    };
    if !rows.is_sorted_by(|a, b| ordered(a, b).is_le()) {
        let mut sorted = rows.to_vec();
        sorted.sort_by(ordered);
        return summarise(&sorted);
    }
    let first = rows.first();
    Summary {
        planner: first.map(|r| r.planner.clone()).unwrap_or_default(),
        vehicle: first.map(|r| r.vehicle.clone()).unwrap_or_default(),
        scale: first.map_or(1.0, |r| r.scale),
        task_set_version: first
            .map(|r| r.task_set_version.clone())
            .unwrap_or_default(),
        sim_version: first.map(|r| r.sim_version.clone()).unwrap_or_default(),
        rules: first.map(|r| r.rules).unwrap_or_default(),
        perception: first.map(|r| r.perception.clone()).unwrap_or_default(),
        overall: aggregate(rows),
        by_level: breakdown(rows, |r| r.level),
        by_semantics: breakdown(rows, |r| r.semantics),
        by_density: breakdown(rows, |r| r.density),
        semantics_level_adjusted: semantics_level_adjusted(rows),
        density_matched: density_matched(rows),
        episode_wall_s: rows.iter().map(|r| r.wall_time_s).sum(),
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
            level: level.parse().unwrap(),
            reason: outcome.parse().unwrap(),
            metrics: contracts::EpisodeMetrics {
                time,
                ..Default::default()
            },
            ..EpisodeRow::for_test(&format!("w001-t{time}"), outcome)
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
        assert_eq!(s.by_level[&ElevationLevel::Low].success_rate, 1.0);
        assert_eq!(s.by_level[&ElevationLevel::High].rollover_pct, 50.0);
        // Rigid (the only kind): low 2/2, high 0/2: standardised over the two levels, 50%.
        assert_eq!(s.semantics_level_adjusted[&SemanticsKind::Rigid], 0.5);
        // A kind with more low (easy) worlds is not favoured: 3 of 3 low and 1 of 4 high against 1 of 1 low and
        // 1 of 4 high give the same adjusted rate, (1 + 1/4) / 2.
        let mut rows = Vec::new();
        for (sem, low_ok, low_n) in [("rigid", 3, 3), ("mixed", 1, 1)] {
            for k in 0..low_n {
                let mut r = row(if k < low_ok { "success" } else { "stuck" }, 1.0, "low");
                r.semantics = sem.parse().unwrap();
                rows.push(r);
            }
            for k in 0..4 {
                let mut r = row(if k < 1 { "success" } else { "stuck" }, 1.0, "high");
                r.semantics = sem.parse().unwrap();
                rows.push(r);
            }
        }
        let adj = semantics_level_adjusted(&rows);
        assert_eq!(adj[&SemanticsKind::Rigid], 0.625);
        assert_eq!(adj[&SemanticsKind::Mixed], 0.625);
    }

    #[test]
    fn the_summary_does_not_depend_on_the_rows_order() {
        // Times whose sum depends on the order of addition in f64: (0.1 + 0.2) + 0.3 != 0.1 + (0.2 + 0.3).
        let rows: Vec<EpisodeRow> = [0.1, 0.2, 0.3, 1e16, 1.0]
            .iter()
            .enumerate()
            .map(|(k, &time)| EpisodeRow {
                task_index: k as u32,
                metrics: contracts::EpisodeMetrics {
                    time,
                    ..Default::default()
                },
                ..EpisodeRow::for_test(&format!("w001-t{k}"), "success")
            })
            .collect();
        let forward = serde_json::to_value(summarise(&rows)).unwrap();
        for order in [[4, 3, 2, 1, 0], [2, 0, 4, 1, 3]] {
            let shuffled: Vec<EpisodeRow> = order.iter().map(|&k| rows[k].clone()).collect();
            assert_eq!(serde_json::to_value(summarise(&shuffled)).unwrap(), forward);
        }
    }

    #[test]
    fn density_contrasts_pair_tasks_of_one_terrain_group() {
        // One world per (terrain group, density), as the task set nests them.
        let row = |terrain: u32, index: u32, density: &str, ok: bool| {
            let d = ["sparse", "medium", "dense"]
                .iter()
                .position(|x| *x == density);
            let world = terrain * 10 + d.unwrap() as u32;
            EpisodeRow {
                world_id: world,
                task_index: index,
                density: density.parse().unwrap(),
                terrain: Some(terrain),
                ..EpisodeRow::for_test(
                    &format!("w{world:03}-t{index}"),
                    if ok { "success" } else { "stuck" },
                )
            }
        };
        let mut rows = Vec::new();
        // Group 1: all succeed sparse; task 0 fails dense. Group 2: task 1 succeeds only at medium density.
        for k in 0..2 {
            rows.push(row(1, k, "sparse", true));
            rows.push(row(1, k, "medium", true));
            rows.push(row(1, k, "dense", k != 0));
            rows.push(row(2, k, "sparse", false));
            rows.push(row(2, k, "medium", k == 1));
        }
        // A task without a partner at another density is not paired.
        rows.push(row(3, 0, "dense", false));
        let c = density_matched(&rows);
        assert_eq!(c.len(), 3);
        let (sm, md, sd) = (&c[0], &c[1], &c[2]);
        assert_eq!(
            (sm.sparser.as_str(), sm.denser.as_str()),
            ("sparse", "medium")
        );
        assert_eq!(sm.comparison.paired_tasks, 4);
        assert_eq!((sm.comparison.a_only, sm.comparison.b_only), (1, 0));
        assert_eq!(md.comparison.paired_tasks, 2);
        assert_eq!((md.comparison.a_only, md.comparison.b_only), (0, 1));
        assert_eq!(sd.comparison.paired_tasks, 2);
        assert_eq!(sd.comparison.difference, -0.5);
        // Rows without a terrain group give no contrast.
        let ungrouped: Vec<EpisodeRow> = rows
            .into_iter()
            .map(|mut r| {
                r.terrain = None;
                r
            })
            .collect();
        assert!(density_matched(&ungrouped).is_empty());
    }
}
