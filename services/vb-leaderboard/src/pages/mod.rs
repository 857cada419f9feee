//! Every page of the leaderboard, rendered by askama from `web/templates/` (compiled in and checked at build
//! time). Askama escapes every `{{ value }}` for HTML; the only unescaped insertions are the page frame's own
//! style sheet and SVG charts that our templates rendered ([`results::charts::Markup`]). Askama leaves control,
//! bidirectional and invisible characters as they are; [`render`] shows them escaped on every page.
//!
//! Why askama: templates are checked against their Rust view structs when the crate compiles (a missing field or a
//! typo fails the build, not a request), escaping is on by default for `.html` and `.svg`, the templates stay
//! plain HTML files in `web/templates/`, and nothing is read from disk at run time. maud escapes too but writes
//! pages as Rust macros; minijinja checks templates only at run time.
//!
//! Pages: [`board`] (the service's `/` and `vb leaderboard-static`, one template), [`submission`], [`episode`]
//! and [`compare`].

pub mod board;
pub mod compare;
pub mod episode;
pub mod robustness;
pub mod submission;

use askama::Template;
use base64::Engine as _;
use results::summary::Aggregate;
use sha2::Digest;

/// Pixels per heightmap sample of world pictures.
pub const MAP_PPM: u32 = 4;

const STYLE: &str = include_str!("../../../../web/static/style.css");

/// The style sheet, served at `/static/style.css`.
pub fn style_css() -> &'static str {
    STYLE
}

/// The frame every page shares (`layout.html`).
pub struct Frame {
    pub title: String,
    /// A running submission's pages refresh themselves.
    pub refresh: bool,
    /// The brand link's target.
    pub home: &'static str,
    /// A page that stands alone as a file (`vb leaderboard-static`): the style inline, allowed by its hash.
    pub inline: Option<Inline>,
}

impl Frame {
    /// A page of the service (its style sheet and Content-Security-Policy come from the server).
    pub fn served(title: &str, refresh: bool) -> Frame {
        Frame {
            title: title.to_string(),
            refresh,
            home: "/",
            inline: None,
        }
    }

    /// A page opened from a file: the style inline and a Content-Security-Policy in a `<meta>` that allows only
    /// that style (by its SHA-256) and nothing else.
    pub fn standalone(title: &str) -> Frame {
        Frame {
            title: title.to_string(),
            refresh: false,
            home: "#",
            inline: Some(Inline {
                csp: standalone_csp(),
                css: STYLE,
            }),
        }
    }
}

pub struct Inline {
    pub csp: String,
    pub css: &'static str,
}

/// The Content-Security-Policy of a standalone page: no scripts, no sources, only the inline style with this hash.
pub fn standalone_csp() -> String {
    let hash = sha2::Sha256::digest(STYLE.as_bytes());
    format!(
        "default-src 'none'; style-src 'sha256-{}'; base-uri 'none'; form-action 'none'",
        base64::engine::general_purpose::STANDARD.encode(hash)
    )
}

/// The cells of one aggregate, formatted (`macros.html`, `agg_cells`).
pub struct AggView {
    pub episodes: u32,
    pub success: String,
    pub ci: String,
    pub time: String,
    pub roll: String,
    pub pitch: String,
    pub rollover: String,
    pub stuck: String,
    pub timeout: String,
    pub other: String,
}

impl AggView {
    pub fn new(a: &Aggregate) -> AggView {
        AggView {
            episodes: a.episodes as u32,
            success: format!("{:.1}%", 100.0 * a.success_rate),
            ci: format!(
                "[{:.1}, {:.1}]",
                100.0 * a.success_ci95.0,
                100.0 * a.success_ci95.1
            ),
            time: if a.success_rate > 0.0 {
                format!("{:.1}", a.traversal_time_mean)
            } else {
                "-".into()
            },
            roll: format!("{:.2}", a.roll_mean),
            pitch: format!("{:.2}", a.pitch_mean),
            rollover: format!("{:.1}%", a.rollover_pct),
            stuck: format!("{:.1}%", a.stuck_pct),
            timeout: format!("{:.1}%", a.timeout_pct),
            other: format!("{:.1}%", a.planner_failure_pct + a.off_map_pct),
        }
    }
}

/// A paired comparison's cells, formatted: A's and B's success rates, A minus B in points with its 95% interval, the
/// discordant pairs and the exact McNemar test (`*` when p < 0.05).
pub struct PairedCells {
    pub tasks: usize,
    pub rate_a: String,
    pub rate_b: String,
    pub difference: String,
    pub ci: String,
    pub discordant: String,
    pub mcnemar: String,
}

impl PairedCells {
    pub fn new(c: &results::compare::Comparison) -> PairedCells {
        PairedCells {
            tasks: c.paired_tasks,
            rate_a: format!("{:.1}%", 100.0 * c.success_a),
            rate_b: format!("{:.1}%", 100.0 * c.success_b),
            difference: format!("{:+.1}", 100.0 * c.difference),
            ci: format!(
                "[{:+.1}, {:+.1}]",
                100.0 * c.difference_ci95.0,
                100.0 * c.difference_ci95.1
            ),
            discordant: format!("{} / {}", c.a_only, c.b_only),
            mcnemar: format!(
                "{}{}",
                results::compare::p_text(c.mcnemar_p),
                if c.significant { " *" } else { "" }
            ),
        }
    }
}

/// Renders a page (as [`results::charts::Markup::render`] renders any of our templates), with every control,
/// bidirectional or invisible character shown as its escape ([`contracts::input::shown_lines`]; line feeds and
/// tabs kept): names stored before such characters were refused, a worker's detail, whatever a field carries, on
/// every page this module renders. Our templates and style sheet carry none.
pub(crate) fn render(t: &impl Template) -> String {
    let page = results::charts::Markup::render(t).into_string();
    match contracts::input::shown_lines(&page) {
        std::borrow::Cow::Borrowed(_) => page,
        std::borrow::Cow::Owned(shown) => shown,
    }
}
