//! The ranking (`board.html`): the service's `/` and `vb leaderboard-static` render the same template.

use super::{render, AggView, Frame};
use crate::SubmissionEntry;
use askama::Template;
use eval::report::{DENSITIES, LEVELS, SEMANTICS};
use eval::summary::{Aggregate, Summary};
use std::collections::BTreeMap;

pub struct Row {
    pub rank: String,
    pub name: String,
    pub href: Option<String>,
    pub planner: String,
    pub vehicle: String,
    pub state: String,
    pub progress: String,
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
    ranked_rule: &'static str,
    /// What a row is: a submission (service) or an evaluation directory (static).
    name_header: &'static str,
    empty: &'static str,
    /// State and progress columns (the service's board; a static board has finished evaluations only).
    live_columns: bool,
    rows: Vec<Row>,
}

/// Success rates of a factor's three levels, `52% / 31% / -`.
fn trio(m: &BTreeMap<String, Aggregate>, keys: [&str; 3]) -> String {
    keys.iter()
        .map(|k| {
            m.get(*k).map_or("-".to_string(), |a| {
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
        planner: s.planner.clone(),
        vehicle: s.vehicle.clone(),
        state: String::new(),
        progress: String::new(),
        overall: AggView::new(&s.overall),
        by_level: trio(&s.by_level, LEVELS),
        by_semantics: trio(&s.by_semantics, SEMANTICS),
        by_density: trio(&s.by_density, DENSITIES),
        task_set: s.task_set_version.clone(),
        simulator: s.sim_version.clone(),
        rules: s.rules.as_str().to_string(),
    }
}

/// The service's ranking page over its (already ranked) submissions.
pub fn index(entries: &[SubmissionEntry]) -> String {
    let mut running = false;
    let rows = entries
        .iter()
        .map(|e| {
            let s = &e.submission;
            running |= s.state == "running" || s.state == "queued";
            Row {
                href: Some(format!("/submissions/{}", s.id)),
                planner: crate::pages::submission::planner_label(s),
                state: s.state.clone(),
                progress: format!("{}/{}", e.progress.finished, e.progress.total),
                ..row(e.rank, &s.name, &e.summary)
            }
        })
        .collect();
    render(&Board {
        frame: Frame::served("leaderboard", running),
        ranked_rule: "submissions that finished every task of the task set.",
        name_header: "submission",
        empty: "No submissions yet. Submit one with `vb-submit builtin pid`.",
        live_columns: true,
        rows,
    })
}

/// One evaluation on a static board: its summary and how many tasks make the full set it ran on (`None` when
/// unknown: the largest evaluation on the same task set counts as full then).
pub struct Evaluation {
    /// What the board calls it (the evaluation's directory name).
    pub name: String,
    pub summary: Summary,
    pub full_tasks: Option<usize>,
}

/// A page that stands alone (`vb leaderboard-static`): evaluations that ran every task of their task set are
/// ranked by success rate; partial ones follow, unranked.
pub fn standalone(evals: &[Evaluation]) -> String {
    let full = |e: &Evaluation| {
        e.full_tasks.unwrap_or_else(|| {
            evals
                .iter()
                .filter(|o| o.summary.task_set_version == e.summary.task_set_version)
                .map(|o| o.summary.overall.episodes)
                .max()
                .unwrap_or(0)
        })
    };
    let complete =
        |e: &Evaluation| e.summary.overall.episodes > 0 && e.summary.overall.episodes == full(e);
    let mut order: Vec<&Evaluation> = evals.iter().collect();
    order.sort_by(|a, b| {
        complete(b).cmp(&complete(a)).then(
            b.summary
                .overall
                .success_rate
                .total_cmp(&a.summary.overall.success_rate),
        )
    });
    let mut rank = 0;
    let rows = order
        .into_iter()
        .map(|e| {
            let r = complete(e).then(|| {
                rank += 1;
                rank
            });
            row(r, &e.name, &e.summary)
        })
        .collect();
    render(&Board {
        frame: Frame::standalone("leaderboard"),
        ranked_rule: "evaluations that ran every task of their task set.",
        name_header: "evaluation",
        empty: "No evaluations.",
        live_columns: false,
        rows,
    })
}
