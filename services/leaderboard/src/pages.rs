//! Server-rendered HTML pages (layout from `web/templates/layout.html`).

use crate::SubmissionEntry;
use eval::summary::Aggregate;
use sim_core::world::{Task, World};
use std::collections::BTreeMap;
use std::fmt::Write;
use vb_store::{EpisodeDetail, EpisodeRecord, Submission};

const LAYOUT: &str = include_str!("../../../web/templates/layout.html");

/// Pixels per heightmap sample of world pictures.
pub const MAP_PPM: u32 = 4;

/// Escapes text for HTML.
pub fn esc(s: &str) -> String {
    eval::report::escape_html(s)
}

fn layout(title: &str, body: &str, refresh: bool) -> String {
    LAYOUT
        .replace(
            "{{refresh}}",
            if refresh {
                "<meta http-equiv=\"refresh\" content=\"3\">"
            } else {
                ""
            },
        )
        .replace("{{title}}", &esc(title))
        .replace("{{body}}", body)
}

fn pct(x: f64) -> String {
    format!("{:.1}%", 100.0 * x)
}

fn agg_cells(a: &Aggregate) -> String {
    if a.episodes == 0 {
        return "<td>0</td><td colspan='9' class='empty l'>no finished episodes</td>".into();
    }
    format!(
        "<td>{}</td><td>{}</td><td>[{:.1}, {:.1}]</td><td>{}</td><td>{:.2}</td><td>{:.2}</td><td>{:.1}%</td><td>{:.1}%</td><td>{:.1}%</td><td>{:.1}%</td>",
        a.episodes,
        pct(a.success_rate),
        100.0 * a.success_ci95.0,
        100.0 * a.success_ci95.1,
        if a.success_rate > 0.0 { format!("{:.1}", a.traversal_time_mean) } else { "-".into() },
        a.roll_mean,
        a.pitch_mean,
        a.rollover_pct,
        a.stuck_pct,
        a.timeout_pct,
        a.planner_failure_pct + a.off_map_pct,
    )
}

const AGG_HEADER: &str = "<th>episodes</th><th>success</th><th>95% CI</th><th>time (s)</th><th>roll (°)</th><th>pitch (°)</th><th>rollover</th><th>stuck</th><th>timeout</th><th>planner failure / off map</th>";

fn progress_bar(done: u32, total: u32) -> String {
    // A <progress> element: the page needs no inline style (the Content-Security-Policy allows none).
    format!(
        "<progress class='bar' value='{done}' max='{}'></progress> {done} / {total}",
        total.max(1)
    )
}

pub fn index(entries: &[SubmissionEntry]) -> String {
    let mut b = String::from(
        "<h1>Leaderboard</h1>\n<p class='note'>Ranked: submissions that finished every task of the task set. \
         Partial runs (fewer tasks, cancelled or still running) are listed after them, unranked (-).</p>\n",
    );
    if entries.is_empty() {
        b.push_str("<p class='empty'>No submissions yet. Submit one with <code>vb-submit builtin pid</code>.</p>");
        return layout("leaderboard", &b, false);
    }
    b.push_str("<table id='ranking'><tr><th>rank</th><th class='l'>submission</th><th class='l'>planner</th><th class='l'>vehicle</th><th class='l'>state</th><th>progress</th>");
    b.push_str(AGG_HEADER);
    b.push_str("<th>low / medium / high</th><th>rigid / deformable / mixed</th><th>sparse / medium / dense</th></tr>\n");
    let trio = |m: &BTreeMap<String, Aggregate>, keys: [&str; 3]| {
        keys.iter()
            .map(|k| {
                m.get(*k).map_or("-".to_string(), |a| {
                    format!("{:.0}%", 100.0 * a.success_rate)
                })
            })
            .collect::<Vec<_>>()
            .join(" / ")
    };
    let mut running = false;
    for e in entries {
        let s = &e.submission;
        running |= s.state == "running" || s.state == "queued";
        let _ = writeln!(
            b,
            "<tr><td>{}</td><td class='l'><a href='/submissions/{id}'>{}</a></td><td class='l'>{}</td><td class='l'>{}</td><td class='l state-{st}'>{st}</td><td>{}/{}</td>{}<td>{}</td><td>{}</td><td>{}</td></tr>",
            e.rank.map_or("-".into(), |r| r.to_string()),
            esc(&s.name),
            esc(&planner_label(s)),
            esc(&s.vehicle),
            e.progress.finished,
            e.progress.total,
            agg_cells(&e.summary.overall),
            trio(&e.summary.by_level, eval::report::LEVELS),
            trio(&e.summary.by_semantics, eval::report::SEMANTICS),
            trio(&e.summary.by_density, eval::report::DENSITIES),
            id = esc(&s.id),
            st = esc(&s.state),
        );
    }
    b.push_str("</table>\n");
    layout("leaderboard", &b, running)
}

fn breakdown_table(
    title: &str,
    id: &str,
    map: &BTreeMap<String, Aggregate>,
    order: [&str; 3],
) -> String {
    let mut t = format!(
        "<h3>{}</h3><table id='{id}'><tr><th class='l'>{}</th>{AGG_HEADER}</tr>\n",
        esc(title),
        esc(title)
    );
    for k in order {
        if let Some(a) = map.get(k) {
            let _ = writeln!(t, "<tr><td class='l'>{k}</td>{}</tr>", agg_cells(a));
        }
    }
    t + "</table>\n"
}

/// `builtin:pid`, or the kind alone (the public does not see command lines, URLs or image names).
fn planner_label(s: &Submission) -> String {
    if s.planner_spec.is_empty() {
        s.planner_kind.clone()
    } else {
        format!("{}:{}", s.planner_kind, s.planner_spec)
    }
}

fn repro(s: &Submission) -> String {
    let rows = [
        ("submission", s.id.clone()),
        ("owner", s.owner.clone()),
        ("planner", planner_label(s)),
        ("planner identity", s.planner_identity.clone()),
        ("vehicle", format!("{} at scale {}", s.vehicle, s.scale)),
        ("seed", s.seed.to_string()),
        ("per-step deadline", format!("{} s", s.step_deadline_s)),
        ("task set", s.task_set_version.clone()),
        ("simulator", s.sim_version.clone()),
    ];
    let mut h = String::from("<dl class='repro' id='repro'>");
    for (k, v) in rows {
        let _ = write!(h, "<dt>{k}</dt><dd>{}</dd>", esc(&v));
    }
    h + "</dl>\n"
}

pub fn submission(e: &SubmissionEntry, eps: &[EpisodeRecord]) -> String {
    let s = &e.submission;
    let p = &e.progress;
    let live = s.state == "queued" || s.state == "running";
    let mut b = format!(
        "<h1>{}</h1>\n<p>State: <b class='state-{st}' id='state'>{st}</b> &nbsp; {}",
        esc(&s.name),
        progress_bar(p.finished, p.total),
        st = esc(&s.state)
    );
    if live {
        let _ = write!(
            b,
            " &nbsp; running {} · queued {} · submissions ahead in the queue: {} (this page refreshes itself)",
            p.running, p.queued, p.queue_position
        );
    }
    if p.not_run > 0 {
        let _ = write!(
            b,
            " &nbsp; <b>{} episodes not run</b> (cancelled before they ran)",
            p.not_run
        );
    }
    b.push_str("</p>\n");
    b.push_str(&repro(s));
    let sum = &e.summary;
    b.push_str("<h2>Summary</h2>");
    let _ = writeln!(b, "<table id='overall'><tr><th class='l'></th>{AGG_HEADER}</tr><tr><td class='l'>all finished</td>{}</tr></table>", agg_cells(&sum.overall));
    if sum.overall.episodes > 0 {
        b.push_str("<h2>Breakdowns</h2><div class='charts'>");
        b.push_str(&eval::report::charts_svg(sum));
        b.push_str("</div>");
        b.push_str(&breakdown_table(
            "elevation level",
            "by-level",
            &sum.by_level,
            eval::report::LEVELS,
        ));
        b.push_str(&breakdown_table(
            "terrain semantics",
            "by-semantics",
            &sum.by_semantics,
            eval::report::SEMANTICS,
        ));
        b.push_str(&breakdown_table(
            "obstacle density",
            "by-density",
            &sum.by_density,
            eval::report::DENSITIES,
        ));
        b.push_str(&matched_density_table(&sum.density_matched));
    }
    b.push_str("<h2>Episodes</h2><table id='episodes'><tr><th class='l'>task</th><th class='l'>level</th><th class='l'>semantics</th><th class='l'>density</th><th class='l'>state</th><th class='l'>outcome</th><th class='l'>reason</th><th>time (s)</th><th>attempts</th><th class='l'>detail</th></tr>\n");
    for ep in eps {
        let outcome = ep.outcome.clone().unwrap_or_default();
        let time = ep
            .metrics_json
            .as_deref()
            .and_then(|m| serde_json::from_str::<sim_core::episode::EpisodeMetrics>(m).ok())
            .map_or("-".into(), |m| format!("{:.1}", m.time));
        let state = if ep.state == "not_run" {
            "not run".to_string()
        } else {
            ep.state.clone()
        };
        let mut detail = ep.detail.clone().unwrap_or_default();
        if detail.len() > 160 {
            let mut cut = 160;
            while !detail.is_char_boundary(cut) {
                cut -= 1;
            }
            detail.truncate(cut);
            detail.push('…');
        }
        let _ = writeln!(
            b,
            "<tr><td class='l'><a href='/submissions/{}/episodes/{t}'>{t}</a></td><td class='l'>{}</td><td class='l'>{}</td><td class='l'>{}</td><td class='l'>{}</td><td class='l outcome-{o}'>{o}</td><td class='l'>{}</td><td>{time}</td><td>{}</td><td class='l'>{}</td></tr>",
            esc(&s.id),
            esc(&ep.level),
            esc(&ep.semantics),
            esc(&ep.density),
            esc(&state),
            esc(ep.reason.as_deref().unwrap_or("")),
            ep.attempts,
            esc(&detail),
            t = esc(&ep.task_id),
            o = esc(&outcome),
        );
    }
    b.push_str("</table>\n");
    layout(&s.name, &b, live)
}

/// Parsed trajectory: time and (x, y, roll°, pitch°, speed).
fn parse_trajectory(csv: &str) -> Vec<[f64; 6]> {
    csv.lines()
        .skip(1)
        .filter_map(|l| {
            let v: Vec<f64> = l.split(',').filter_map(|x| x.parse().ok()).collect();
            (v.len() >= 8).then(|| [v[0], v[1], v[2], v[4].to_degrees(), v[5].to_degrees(), v[7]])
        })
        .collect()
}

fn line_chart(title: &str, id: &str, unit: &str, pts: &[(f64, f64)]) -> String {
    let (w, h, l, r, t, bo) = (420.0, 180.0, 44.0, 10.0, 22.0, 24.0);
    let mut svg = format!("<svg id='{id}' xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' font-family='sans-serif' font-size='11'><text x='8' y='14'>{} ({unit})</text>", esc(title));
    if pts.is_empty() {
        return svg + "<text x='40' y='90'>no samples</text></svg>";
    }
    let tmax = pts.iter().map(|p| p.0).fold(0.0, f64::max).max(1e-6);
    let (mut lo, mut hi) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if hi - lo < 1e-6 {
        lo -= 1.0;
        hi += 1.0;
    }
    let x = |v: f64| l + (w - l - r) * v / tmax;
    let y = |v: f64| t + (h - t - bo) * (1.0 - (v - lo) / (hi - lo));
    let _ = write!(
        svg,
        "<line x1='{l}' x2='{l}' y1='{t}' y2='{:.0}' stroke='#999'/><line x1='{l}' x2='{:.0}' y1='{:.0}' y2='{:.0}' stroke='#999'/>",
        h - bo,
        w - r,
        h - bo,
        h - bo
    );
    let _ = write!(
        svg,
        "<text x='2' y='{:.0}'>{hi:.1}</text><text x='2' y='{:.0}'>{lo:.1}</text>",
        t + 8.0,
        h - bo
    );
    let _ = write!(
        svg,
        "<text x='{:.0}' y='{:.0}' text-anchor='end'>{tmax:.0} s</text>",
        w - r,
        h - 6.0
    );
    let mut poly = String::new();
    for p in pts {
        let _ = write!(poly, "{:.1},{:.1} ", x(p.0), y(p.1));
    }
    let _ = write!(
        svg,
        "<polyline fill='none' stroke='#4a7fb5' stroke-width='1.5' points='{poly}'/>"
    );
    svg + "</svg>"
}

pub fn episode(sub: &Submission, d: &EpisodeDetail, world_task: Option<&(World, Task)>) -> String {
    let r = &d.record;
    let traj = parse_trajectory(&d.trajectory_csv);
    let mut b = format!(
        "<p><a href='/submissions/{}'>← {}</a></p><h1>Episode {}</h1>\n<p>World {} task {} · {} elevation · {} terrain · {} obstacles</p>\n",
        esc(&sub.id),
        esc(&sub.name),
        esc(&r.task_id),
        r.world_id,
        r.task_index,
        esc(&r.level),
        esc(&r.semantics),
        esc(&r.density)
    );
    let state = if r.state == "not_run" {
        "not run"
    } else {
        r.state.as_str()
    };
    let _ = writeln!(
        b,
        "<dl class='repro' id='result'><dt>state</dt><dd>{}</dd><dt>outcome</dt><dd class='outcome-{o}'>{o}</dd><dt>reason</dt><dd>{}</dd><dt>detail</dt><dd>{}</dd><dt>attempts</dt><dd>{}</dd><dt>planner identity</dt><dd>{}</dd><dt>simulator</dt><dd>{}</dd><dt>worker wall time</dt><dd>{}</dd></dl>",
        esc(state),
        esc(r.reason.as_deref().unwrap_or("")),
        esc(r.detail.as_deref().unwrap_or("")),
        r.attempts,
        esc(r.planner_identity.as_deref().unwrap_or("")),
        esc(r.sim_version.as_deref().unwrap_or("")),
        r.wall_time_s.map_or("-".into(), |t| format!("{t:.2} s")),
        o = esc(r.outcome.as_deref().unwrap_or("")),
    );
    if let Some(m) = r
        .metrics_json
        .as_deref()
        .and_then(|m| serde_json::from_str::<sim_core::episode::EpisodeMetrics>(m).ok())
    {
        let _ = writeln!(
            b,
            "<table id='metrics'><tr><th>time (s)</th><th>path length (m)</th><th>mean |roll| (°)</th><th>max |roll| (°)</th><th>mean |pitch| (°)</th><th>max |pitch| (°)</th><th>energy (kJ)</th><th>obstacle contacts</th><th>final distance to goal (m)</th></tr><tr><td>{:.1}</td><td>{:.1}</td><td>{:.2}</td><td>{:.1}</td><td>{:.2}</td><td>{:.1}</td><td>{:.1}</td><td>{}</td><td>{:.1}</td></tr></table>",
            m.time, m.path_length, m.roll_abs.mean, m.roll_abs.max, m.pitch_abs.mean, m.pitch_abs.max, m.energy / 1000.0, m.obstacle_contacts, m.final_goal_distance
        );
    }
    // The map with the global path, the driven trajectory, start and goal.
    if let Some((world, task)) = world_task {
        let h = &world.heightmap;
        let ppm = MAP_PPM as f64;
        let (wpx, hpx) = (h.nx as f64 * ppm, h.ny as f64 * ppm);
        let s = if sub.scale > 0.0 { sub.scale } else { 1.0 };
        // Full-scale world coordinates to picture pixels (the picture is drawn at full scale).
        let px = |x: f64, y: f64| {
            let (fx, fy) = h.grid_coords(x / s, y / s);
            ((fx + 0.5) * ppm, (h.ny as f64 - 1.0 - fy + 0.5) * ppm)
        };
        let pxw = |x: f64, y: f64| px(x * s, y * s);
        let mut svg = format!("<svg id='map' xmlns='http://www.w3.org/2000/svg' width='{wpx:.0}' height='{hpx:.0}' viewBox='0 0 {wpx:.0} {hpx:.0}'><image href='/worlds/{}.png' x='0' y='0' width='{wpx:.0}' height='{hpx:.0}'/>", world.id);
        let mut path = String::new();
        for p in &task.path {
            let (a, c) = pxw(p[0], p[1]);
            let _ = write!(path, "{a:.1},{c:.1} ");
        }
        let _ = write!(svg, "<polyline fill='none' stroke='#dc1e1e' stroke-width='2' stroke-dasharray='6 4' points='{path}'/>");
        let mut tr = String::new();
        for p in &traj {
            let (a, c) = px(p[1], p[2]);
            let _ = write!(tr, "{a:.1},{c:.1} ");
        }
        let _ = write!(svg, "<polyline id='trajectory' fill='none' stroke='#ffd400' stroke-width='3' points='{tr}'/>");
        let (sx, sy) = pxw(task.start[0], task.start[1]);
        let (gx, gy) = pxw(task.goal[0], task.goal[1]);
        let _ = write!(svg, "<circle cx='{sx:.1}' cy='{sy:.1}' r='7' fill='#1ec83c' stroke='#fff'/><circle cx='{gx:.1}' cy='{gy:.1}' r='7' fill='#1e3cdc' stroke='#fff'/></svg>");
        b.push_str("<h2>Path over the map</h2><p>dashed red: global path · yellow: driven trajectory · green: start · blue: goal</p>");
        b.push_str(&svg);
    }
    b.push_str("<h2>Over time</h2><div class='charts'>");
    b.push_str(&line_chart(
        "roll",
        "roll-chart",
        "°",
        &traj.iter().map(|p| (p[0], p[3])).collect::<Vec<_>>(),
    ));
    b.push_str(&line_chart(
        "pitch",
        "pitch-chart",
        "°",
        &traj.iter().map(|p| (p[0], p[4])).collect::<Vec<_>>(),
    ));
    b.push_str(&line_chart(
        "speed",
        "speed-chart",
        "m/s",
        &traj.iter().map(|p| (p[0], p[5])).collect::<Vec<_>>(),
    ));
    b.push_str("</div>");
    b.push_str("<h2>Planner log</h2>");
    if d.planner_log.is_empty() {
        b.push_str("<p class='empty'>The planner wrote nothing.</p>");
    } else {
        let _ = write!(b, "<pre class='log' id='log'>{}</pre>", esc(&d.planner_log));
    }
    let live = r.state == "queued" || r.state == "leased";
    layout(&r.task_id, &b, live)
}

/// The density contrasts on matched tasks (same terrain group and start/goal pair), when the summary has them.
fn matched_density_table(contrasts: &[eval::summary::DensityContrast]) -> String {
    if contrasts.is_empty() {
        return String::new();
    }
    let mut t = String::from("<h3>Obstacle density on matched tasks</h3><p>The same terrain and start/goal pair at two densities (nested obstacle layouts); difference = denser minus sparser, exact McNemar test.</p><table id='density-matched'><tr><th class='l'>contrast</th><th>tasks</th><th>sparser</th><th>denser</th><th>difference (points)</th><th>95% CI</th><th>McNemar</th></tr>\n");
    for c in contrasts {
        let m = &c.comparison;
        let _ = writeln!(
            t,
            "<tr><td class='l'>{} &rarr; {}</td><td>{}</td><td>{:.1}%</td><td>{:.1}%</td><td>{:+.1}</td><td>[{:+.1}, {:+.1}]</td><td>{}{}</td></tr>",
            esc(&c.sparser),
            esc(&c.denser),
            m.paired_tasks,
            100.0 * m.success_b,
            100.0 * m.success_a,
            100.0 * m.difference,
            100.0 * m.difference_ci95.0,
            100.0 * m.difference_ci95.1,
            esc(&eval::compare::p_text(m.mcnemar_p)),
            if m.significant { " *" } else { "" }
        );
    }
    t + "</table>\n"
}
