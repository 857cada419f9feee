//! A submission's page (`submission.html`): state and progress, reproducibility facts, summary, breakdowns with
//! charts, matched density contrasts and its episodes, a page of [`PAGE_SIZE`] at a time.

use super::{render, AggView, Frame};
use crate::public::PublicSubmission;
use crate::SubmissionEntry;
use askama::Template;
use results::summary::named;
use results::summary::Aggregate;
use vb_store::EpisodeRecord;

/// Episodes per page of a submission's episode table.
pub const PAGE_SIZE: usize = 100;

struct Breakdown {
    title: &'static str,
    id: &'static str,
    rows: Vec<(String, AggView)>,
}

/// A density contrast: A is the denser layout, B the sparser.
struct Contrast {
    sparser: String,
    denser: String,
    cells: super::PairedCells,
}

struct EpisodeLine {
    href: String,
    task: String,
    level: String,
    semantics: String,
    density: String,
    state: String,
    outcome: String,
    reason: String,
    time: String,
    attempts: i64,
    detail: String,
}

struct Pager {
    info: String,
    prev: Option<String>,
    next: Option<String>,
}

#[derive(Template)]
#[template(path = "submission.html")]
struct Page {
    frame: Frame,
    name: String,
    state: String,
    finished: u32,
    total: u32,
    total_max: u32,
    live: Option<String>,
    not_run: u32,
    repro: Vec<(&'static str, String)>,
    overall: AggView,
    charts: Option<results::charts::Markup>,
    breakdowns: Vec<Breakdown>,
    matched: Vec<Contrast>,
    page: Pager,
    episodes: Vec<EpisodeLine>,
    /// Links to comparisons with other submissions: (name, href).
    compare: Vec<(String, String)>,
    /// Its family's profiles, when it was submitted under several.
    robustness: Vec<super::robustness::RobustRow>,
}

/// Submissions a page offers to compare with: the ranked ones first, at most [`COMPARE_LINKS`], not `id` itself.
pub fn compare_links(id: &str, ranking: &[SubmissionEntry]) -> Vec<(String, String)> {
    ranking
        .iter()
        .filter(|e| e.submission.id != id && e.summary.overall.episodes > 0)
        .take(COMPARE_LINKS)
        .map(|e| {
            let label = match e.rank {
                Some(r) => format!("#{r} {}", e.submission.name),
                None => e.submission.name.clone(),
            };
            (label, format!("/compare/{id}/{}", e.submission.id))
        })
        .collect()
}

/// Comparison links on a submission page.
pub const COMPARE_LINKS: usize = 10;

/// `builtin:pid`, or the kind alone (the public does not see command lines, URLs or image names).
pub fn planner_label(s: &PublicSubmission) -> String {
    if s.planner_spec.is_empty() {
        s.planner_kind.to_string()
    } else {
        format!("{}:{}", s.planner_kind, s.planner_spec)
    }
}

/// `not_run` reads `not run`.
pub fn state_label(state: &str) -> String {
    state.replace('_', " ")
}

fn repro(s: &PublicSubmission) -> Vec<(&'static str, String)> {
    vec![
        ("submission", s.id.clone()),
        ("owner", s.owner.clone()),
        ("planner", planner_label(s)),
        ("planner identity", s.planner_identity.clone()),
        ("vehicle", format!("{} at scale {}", s.vehicle, s.scale)),
        ("seed", s.seed.to_string()),
        ("per-step deadline", format!("{} s", s.step_deadline_s)),
        ("task set", s.task_set_version.clone()),
        ("simulator", s.sim_version.to_string()),
        ("perception", s.perception.to_string()),
    ]
}

fn breakdown(title: &'static str, id: &'static str, entries: Vec<(&str, &Aggregate)>) -> Breakdown {
    Breakdown {
        title,
        id,
        rows: entries
            .into_iter()
            .map(|(k, a)| (k.to_string(), AggView::new(a)))
            .collect(),
    }
}

fn contrast(c: &results::summary::DensityContrast) -> Contrast {
    Contrast {
        sparser: c.sparser.clone(),
        denser: c.denser.clone(),
        cells: super::PairedCells::new(&c.comparison),
    }
}

/// At most `max` bytes of `s`, cut at a character boundary and marked with `…`.
fn cut(s: &str, max: usize) -> String {
    if s.len() <= max {
        return s.to_string();
    }
    let mut at = max;
    while !s.is_char_boundary(at) {
        at -= 1;
    }
    format!("{}…", &s[..at])
}

fn episode_line(sub_id: &str, ep: &EpisodeRecord) -> EpisodeLine {
    let time = ep
        .metrics
        .as_ref()
        .map_or("-".into(), |m| format!("{:.1}", m.time));
    EpisodeLine {
        href: format!("/submissions/{sub_id}/episodes/{}", ep.task_id),
        task: ep.task_id.to_string(),
        level: ep.level.to_string(),
        semantics: ep.semantics.to_string(),
        density: ep.density.to_string(),
        state: state_label(ep.state.as_str()),
        outcome: ep.outcome.map_or(String::new(), |o| o.as_str().to_string()),
        reason: ep.reason.map_or(String::new(), |e| e.to_string()),
        time,
        attempts: ep.attempts,
        detail: cut(ep.detail.as_deref().unwrap_or(""), 160),
    }
}

/// The page of the episode table that `page` (from 1) asks for among `total` episodes (past the end: the last),
/// and the position of its first episode.
pub fn page_offset(page: usize, total: usize) -> (usize, usize) {
    let page = page.clamp(1, total.div_ceil(PAGE_SIZE).max(1));
    (page, (page - 1) * PAGE_SIZE)
}

/// The page of a submission showing `shown`, its episodes from position `from` (page `page` of its table).
pub fn page(
    e: &SubmissionEntry,
    shown: &[EpisodeRecord],
    page: usize,
    from: usize,
    compare: &[(String, String)],
    family: Option<&crate::robustness::Robustness>,
) -> String {
    let s = &e.submission;
    let p = &e.progress;
    let live = s.state.is_active();
    let sum = &e.summary;
    let total = (s.tasks as usize).max(from + shown.len());
    let pages = total.div_ceil(PAGE_SIZE).max(1);
    let link = |n: usize| format!("/submissions/{}?page={n}", s.id);
    let has_charts = sum.overall.episodes > 0;
    render(&Page {
        frame: Frame::served(&s.name, live),
        name: s.name.clone(),
        state: state_label(s.state.as_str()),
        finished: p.finished,
        total: p.total,
        total_max: p.total.max(1),
        live: live.then(|| {
            format!(
                "running {} · queued {} · submissions ahead in the queue: {}",
                p.running, p.queued, p.queue_position
            )
        }),
        not_run: p.not_run,
        repro: repro(s),
        overall: AggView::new(&sum.overall),
        charts: has_charts.then(|| results::charts::charts_svg(sum)),
        breakdowns: if has_charts {
            vec![
                breakdown("elevation level", "by-level", named(&sum.by_level)),
                breakdown(
                    "terrain semantics",
                    "by-semantics",
                    named(&sum.by_semantics),
                ),
                breakdown("obstacle density", "by-density", named(&sum.by_density)),
            ]
        } else {
            Vec::new()
        },
        matched: sum.density_matched.iter().map(contrast).collect(),
        page: Pager {
            info: if total == 0 {
                "No episodes.".into()
            } else {
                format!(
                    "Episodes {}-{} of {} (page {page} of {pages}).",
                    from + 1,
                    from + shown.len(),
                    total
                )
            },
            prev: (page > 1).then(|| link(page - 1)),
            next: (page < pages).then(|| link(page + 1)),
        },
        episodes: shown.iter().map(|ep| episode_line(&s.id, ep)).collect(),
        compare: compare.to_vec(),
        robustness: super::robustness::rows(family.map(std::slice::from_ref).unwrap_or_default()),
    })
}
