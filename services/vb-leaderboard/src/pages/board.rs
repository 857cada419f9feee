//! The ranking (`board.html`): the service's `/` and `vb leaderboard-static` render the same template.

use super::{render, AggView, Frame};
use crate::ranking::{coverage_text, Reference, Run, Unranked};
use crate::SubmissionEntry;
use askama::Template;
use contracts::SubmissionState;
use results::summary::Factor;
use results::summary::{Aggregate, Summary};
use std::collections::BTreeMap;

pub struct Row {
    pub rank: String,
    pub name: String,
    pub href: Option<String>,
    pub planner: String,
    pub vehicle: String,
    pub state: String,
    pub progress: String,
    /// Finished tasks of the full set (runs listed apart).
    pub coverage: String,
    /// Why a run is listed apart (empty for ranked ones).
    pub why: String,
    pub overall: AggView,
    pub by_level: String,
    pub by_semantics: String,
    pub by_density: String,
    pub task_set: String,
    pub simulator: String,
    pub rules: String,
}

#[derive(Template)]
#[template(path = "board.html")]
struct Board {
    frame: Frame,
    /// What ranked runs ran ([`Reference::describe`]).
    reference: String,
    /// What a row is: a submission (service) or an evaluation directory (static).
    name_header: &'static str,
    empty: &'static str,
    /// State and progress columns (the service's board; a static board has finished evaluations only).
    live_columns: bool,
    ranked: Vec<Row>,
    apart: Vec<Row>,
    /// Families of submissions under several perception profiles (the service's board).
    robustness: Vec<super::robustness::RobustRow>,
}

impl Board {
    fn new(frame: Frame, reference: &Reference, rows: Vec<Row>) -> Board {
        let (ranked, apart) = rows.into_iter().partition(|r| r.why.is_empty());
        Board {
            frame,
            reference: reference.describe(),
            name_header: "submission",
            empty: "No submissions yet. Submit one with `vb-submit builtin pid`.",
            live_columns: true,
            ranked,
            apart,
            robustness: Vec::new(),
        }
    }
}

/// Success rates of a factor's three levels, `52% / 31% / -`.
/// Success of each of a factor's values (`-` for one the run has no tasks of), in the canonical order.
fn trio<K: Factor>(m: &BTreeMap<K, Aggregate>) -> String {
    K::ALL
        .iter()
        .map(|k| {
            m.get(k).map_or("-".to_string(), |a| {
                format!("{:.0}%", 100.0 * a.success_rate)
            })
        })
        .collect::<Vec<_>>()
        .join(" / ")
}

fn row(rank: Option<usize>, name: &str, s: &Summary) -> Row {
    Row {
        rank: rank.map_or("-".into(), |r| r.to_string()),
        name: name.to_string(),
        href: None,
        planner: s.planner.to_string(),
        vehicle: s.vehicle.to_string(),
        state: String::new(),
        progress: String::new(),
        coverage: String::new(),
        why: String::new(),
        overall: AggView::new(&s.overall),
        by_level: trio(&s.by_level),
        by_semantics: trio(&s.by_semantics),
        by_density: trio(&s.by_density),
        task_set: s.task_set_version.clone(),
        simulator: s.sim_version.to_string(),
        rules: s.rules.as_str().to_string(),
    }
}

/// The service's ranking page over its (already ranked) submissions and their perception families.
pub fn index(
    entries: &[SubmissionEntry],
    reference: &Reference,
    families: &[crate::robustness::Robustness],
) -> String {
    let mut running = false;
    let rows = entries
        .iter()
        .map(|e| {
            let s = &e.submission;
            running |= s.state.is_active();
            Row {
                href: Some(format!("/submissions/{}", s.id)),
                planner: crate::pages::submission::planner_label(s),
                state: s.state.as_str().to_string(),
                progress: format!("{}/{}", e.progress.finished, e.progress.total),
                coverage: coverage_text(e.progress.finished, e.coverage, reference),
                why: e.unranked.as_ref().map_or(String::new(), |u| u.to_string()),
                ..row(e.rank, &s.name, &e.summary)
            }
        })
        .collect();
    render(&Board {
        robustness: super::robustness::rows(families),
        ..Board::new(Frame::served("leaderboard", running), reference, rows)
    })
}

/// One evaluation on a static board: what the board calls it (its directory's name) and its summary.
pub struct Evaluation {
    pub name: String,
    pub summary: Summary,
}

/// A page that stands alone (`vb leaderboard-static`), ranked by the service's rule ([`crate::ranking`]) against
/// `reference` (`None`: the full set is the most common task set among the evaluations, of as many tasks as the
/// largest evaluation on it ran, on simulator `sim_version` under the paper's rules).
pub fn standalone(evals: &[Evaluation], sim_version: &str, reference: Option<Reference>) -> String {
    let reference = reference.unwrap_or_else(|| {
        let mut counts = BTreeMap::<&str, usize>::new();
        for e in evals {
            *counts.entry(&e.summary.task_set_version).or_default() += 1;
        }
        let version = counts
            .iter()
            .max_by_key(|(_, n)| **n)
            .map_or("", |(v, _)| *v);
        let tasks = evals
            .iter()
            .filter(|e| e.summary.task_set_version == version)
            .map(|e| e.summary.overall.episodes as u32)
            .max()
            .unwrap_or(0);
        Reference::current(version, tasks, sim_version)
    });
    fn run(e: &Evaluation) -> Run<'_> {
        let episodes = e.summary.overall.episodes as u32;
        Run {
            state: SubmissionState::Done,
            tasks: episodes,
            finished: episodes,
            task_set_version: &e.summary.task_set_version,
            sim_version: &e.summary.sim_version,
            rules: e.summary.rules,
            perception: &e.summary.perception,
        }
    }
    let mut order: Vec<(&Evaluation, Option<Unranked>)> = evals
        .iter()
        .map(|e| (e, run(e).unranked(&reference)))
        .collect();
    order.sort_by(|(a, ua), (b, ub)| {
        ua.is_some().cmp(&ub.is_some()).then(
            b.summary
                .overall
                .success_rate
                .total_cmp(&a.summary.overall.success_rate),
        )
    });
    let mut rank = 0;
    let rows = order
        .into_iter()
        .map(|(e, why)| {
            let r = why.is_none().then(|| {
                rank += 1;
                rank
            });
            let run = run(e);
            Row {
                coverage: coverage_text(run.finished, run.coverage(&reference), &reference),
                why: why.map_or(String::new(), |u| u.to_string()),
                ..row(r, &e.name, &e.summary)
            }
        })
        .collect();
    render(&Board {
        name_header: "evaluation",
        empty: "No evaluations.",
        live_columns: false,
        ..Board::new(Frame::standalone("leaderboard"), &reference, rows)
    })
}
