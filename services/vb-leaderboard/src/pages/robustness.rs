//! The robustness table (the board's and a family's submission pages): one line per profile of each family, its
//! success, its paired drop from the family's `ideal` run and the McNemar test, and its success per factor.

use crate::robustness::Robustness;
use results::summary::Factor;
use std::collections::BTreeMap;

pub struct RobustRow {
    pub name: String,
    pub href: String,
    pub profile: String,
    pub state: String,
    pub finished: u32,
    pub success: String,
    /// `-12.3 pp (-16.0, -8.6)` on the tasks both finished; empty for the ideal run.
    pub drop: String,
    pub mcnemar: String,
    pub by_level: String,
    pub by_semantics: String,
    pub by_density: String,
}

/// Success of each of a factor's values (`-` for one without tasks), in the canonical order.
fn trio<K: Factor>(m: &BTreeMap<K, f64>) -> String {
    K::ALL
        .iter()
        .map(|k| {
            m.get(k)
                .map_or("-".to_string(), |r| format!("{:.0}%", 100.0 * r))
        })
        .collect::<Vec<_>>()
        .join(" / ")
}

/// The lines of `families`, family by family.
pub fn rows(families: &[Robustness]) -> Vec<RobustRow> {
    let mut out = Vec::new();
    for f in families {
        for p in &f.profiles {
            let (drop, mcnemar) = match &p.drop_from_ideal {
                Some(c) if c.paired_tasks > 0 => (
                    format!(
                        "{:+.1} pp ({:+.1}, {:+.1}) on {} tasks",
                        100.0 * c.difference,
                        100.0 * c.difference_ci95.0,
                        100.0 * c.difference_ci95.1,
                        c.paired_tasks
                    ),
                    results::compare::p_text(c.mcnemar_p),
                ),
                Some(_) => ("no tasks paired yet".into(), String::new()),
                None => (String::new(), String::new()),
            };
            out.push(RobustRow {
                name: f.name.clone(),
                href: format!("/submissions/{}", p.id),
                profile: p.perception.to_string(),
                state: super::submission::state_label(p.state.as_str()),
                finished: p.finished,
                success: format!("{:.1}%", 100.0 * p.success_rate),
                drop,
                mcnemar,
                by_level: trio(&p.by_level),
                by_semantics: trio(&p.by_semantics),
                by_density: trio(&p.by_density),
            });
        }
    }
    out
}
