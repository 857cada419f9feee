//! Paired comparison of two evaluations on the same tasks.

use crate::EpisodeRow;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Result of a paired comparison (A minus B).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    pub paired_tasks: usize,
    pub success_a: f64,
    pub success_b: f64,
    /// Difference of success rates and its 95% interval (paired Wald interval).
    pub difference: f64,
    pub difference_ci95: (f64, f64),
    /// Discordant pairs: A succeeded and B failed, and the reverse.
    pub a_only: usize,
    pub b_only: usize,
    /// Exact two-sided McNemar p-value (binomial test on the discordant pairs).
    pub mcnemar_p: f64,
    pub significant: bool,
}

/// A p-value as text: `p = 0.0123`, or `p < 0.0001` below the fourth decimal (never `p = 0.0000`).
pub fn p_text(p: f64) -> String {
    if p < 1e-4 {
        "p < 0.0001".into()
    } else {
        format!("p = {p:.4}")
    }
}

/// Two-sided exact binomial p-value for k successes in n trials at p = 1/2.
pub fn binomial_two_sided(k: usize, n: usize) -> f64 {
    if n == 0 {
        return 1.0;
    }
    let k = k.min(n - k);
    // log C(n, i) - n log 2, summed for i <= k, doubled.
    let mut log_c = 0.0f64;
    let mut tail = 0.0;
    for i in 0..=k {
        if i > 0 {
            log_c += ((n - i + 1) as f64).ln() - (i as f64).ln();
        }
        tail += (log_c - n as f64 * std::f64::consts::LN_2).exp();
    }
    (2.0 * tail).min(1.0)
}

/// Compares rows of A and B on the tasks both contain.
pub fn compare(a: &[EpisodeRow], b: &[EpisodeRow]) -> Comparison {
    let bm: BTreeMap<contracts::TaskId, bool> =
        b.iter().map(|r| (r.task_id, r.is_success())).collect();
    paired(
        a.iter()
            .filter_map(|r| bm.get(&r.task_id).map(|&ok_b| (r.is_success(), ok_b))),
    )
}

/// A note when A and B ran on different task sets: tasks are paired by id, which is what a surface counterfactual
/// (`vb tasks generate --surface`) is made for and a mistake otherwise.
pub fn task_set_note(a: &[EpisodeRow], b: &[EpisodeRow]) -> Option<String> {
    let versions = |rows: &[EpisodeRow]| {
        rows.iter()
            .map(|r| r.task_set_version.as_str())
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect::<Vec<_>>()
            .join(", ")
    };
    let (va, vb) = (versions(a), versions(b));
    (va != vb).then(|| {
        format!(
            "note: A ran on task set {va}, B on {vb}; tasks are paired by id (right for a surface counterfactual of one \
             set, meaningless for unrelated sets)"
        )
    })
}

/// Paired statistics of (A succeeded, B succeeded) pairs.
pub fn paired(pairs: impl IntoIterator<Item = (bool, bool)>) -> Comparison {
    let (mut n, mut sa, mut sb, mut a_only, mut b_only) = (0usize, 0usize, 0usize, 0usize, 0usize);
    for (ok_a, ok_b) in pairs {
        n += 1;
        sa += ok_a as usize;
        sb += ok_b as usize;
        a_only += (ok_a && !ok_b) as usize;
        b_only += (!ok_a && ok_b) as usize;
    }
    let nf = n.max(1) as f64;
    let d = (a_only as f64 - b_only as f64) / nf;
    let var = ((a_only + b_only) as f64 / nf - d * d) / nf;
    let half = 1.959_963_984_540_054 * var.max(0.0).sqrt();
    let p = binomial_two_sided(a_only, a_only + b_only);
    Comparison {
        paired_tasks: n,
        success_a: sa as f64 / nf,
        success_b: sb as f64 / nf,
        difference: d,
        difference_ci95: (d - half, d + half),
        a_only,
        b_only,
        mcnemar_p: p,
        significant: p < 0.05,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_binomial_p_values() {
        // 0 of 10 at p = 1/2: 2 * 2^-10 = 0.001953; 5 of 10: 1.
        assert!((binomial_two_sided(0, 10) - 0.001953125).abs() < 1e-12);
        assert_eq!(binomial_two_sided(5, 10), 1.0);
        // 2 of 12: 2 * (1 + 12 + 66) / 4096 = 0.03857.
        assert!((binomial_two_sided(2, 12) - 0.038574).abs() < 1e-5);
        assert_eq!(p_text(binomial_two_sided(2, 12)), "p = 0.0386");
        assert_eq!(p_text(binomial_two_sided(0, 30)), "p < 0.0001");
    }

    #[test]
    fn different_task_sets_are_noted_and_paired_by_task_id() {
        let row = |task: &str, version: &str, ok: bool| EpisodeRow {
            terrain: Some(1),
            task_set_version: version.into(),
            ..EpisodeRow::for_test(task, if ok { "success" } else { "stuck" })
        };
        let a = vec![row("w001-t0", "aaa", true), row("w001-t1", "aaa", true)];
        let b = vec![row("w001-t1", "bbb", false), row("w002-t0", "bbb", false)];
        assert_eq!(task_set_note(&a, &a), None);
        let note = task_set_note(&a, &b).unwrap();
        assert!(note.contains("aaa") && note.contains("bbb"), "{note}");
        let c = compare(&a, &b);
        assert_eq!((c.paired_tasks, c.a_only, c.b_only), (1, 1, 0));
    }
}
