//! The comparison of two submissions (`compare.html`): A minus B on the tasks both finished.

use super::{render, Frame};
use crate::compare::{Pairwise, Side};
use askama::Template;
use results::compare::Comparison;

struct SideView {
    href: String,
    name: String,
    facts: String,
}

struct Line {
    label: String,
    cells: super::PairedCells,
}

#[derive(Template)]
#[template(path = "compare.html")]
struct Page {
    frame: Frame,
    a: SideView,
    b: SideView,
    notes: Vec<String>,
    lines: Vec<Line>,
    api: String,
}

fn side(s: &Side) -> SideView {
    SideView {
        href: format!("/submissions/{}", s.id),
        name: s.name.clone(),
        facts: format!(
            "{}, {}, {} finished episodes, task set {}, simulator {}, {} rules",
            s.planner,
            s.state,
            s.finished,
            s.task_set_version,
            s.sim_version,
            s.rules.as_str()
        ),
    }
}

fn line(label: &str, c: &Comparison) -> Line {
    Line {
        label: label.to_string(),
        cells: super::PairedCells::new(c),
    }
}

/// The page of a comparison.
pub fn page(p: &Pairwise) -> String {
    let mut lines = vec![line("all paired tasks", &p.overall)];
    lines.extend(p.by_level.iter().map(|(level, c)| line(level, c)));
    render(&Page {
        frame: Frame::served(&format!("{} vs {}", p.a.name, p.b.name), false),
        a: side(&p.a),
        b: side(&p.b),
        notes: p.notes.clone(),
        lines,
        api: format!("/api/compare/{}/{}", p.a.id, p.b.id),
    })
}
