//! An episode's page (`episode.html`): its result, metrics, the global path and the driven trajectory over the
//! world's map, roll, pitch and speed over time (the planner's log is its owner's: `vb-submit log`).

use super::{render, Frame};
use crate::public::PublicEpisode;
use crate::public::PublicSubmission;
use askama::Template;
use contracts::WorldPicture;
use std::fmt::Write;
use vb_store::EpisodeState;

struct MapView {
    width: String,
    height: String,
    image: String,
    path: String,
    trajectory: String,
    start: (String, String),
    goal: (String, String),
}

struct Plot {
    hi: String,
    lo: String,
    tmax: String,
    points: String,
}

struct LineChart {
    id: &'static str,
    title: &'static str,
    unit: &'static str,
    plot: Option<Plot>,
}

#[derive(Template)]
#[template(path = "episode.html")]
struct Page {
    frame: Frame,
    back_href: String,
    submission_name: String,
    task: contracts::TaskId,
    world: u32,
    task_index: u32,
    level: String,
    semantics: String,
    density: String,
    result: Vec<(&'static str, String)>,
    metrics: Option<Vec<String>>,
    map: Option<MapView>,
    charts: Vec<LineChart>,
    submission_id: String,
}

/// (time, x, y, roll in degrees, pitch in degrees, speed) of each sample.
fn parse_trajectory(samples: &[contracts::TrajectorySample]) -> Vec<[f64; 6]> {
    samples
        .iter()
        .map(|t| {
            [
                t.time,
                t.x,
                t.y,
                t.roll.to_degrees(),
                t.pitch.to_degrees(),
                t.speed,
            ]
        })
        .collect()
}

/// A line chart's polyline in the plot area of `episode.html`'s charts (420 x 180 px: the axes run from x 44 to
/// 410 and from y 22 to 156).
fn plot(pts: &[(f64, f64)]) -> Option<Plot> {
    if pts.is_empty() {
        return None;
    }
    let (l, r, t, b) = (44.0, 410.0, 22.0, 156.0);
    let tmax = pts.iter().map(|p| p.0).fold(0.0, f64::max).max(1e-6);
    let (mut lo, mut hi) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    if hi - lo < 1e-6 {
        lo -= 1.0;
        hi += 1.0;
    }
    let mut points = String::new();
    for p in pts {
        let x = l + (r - l) * p.0 / tmax;
        let y = t + (b - t) * (1.0 - (p.1 - lo) / (hi - lo));
        let _ = write!(points, "{x:.1},{y:.1} ");
    }
    Some(Plot {
        hi: format!("{hi:.1}"),
        lo: format!("{lo:.1}"),
        tmax: format!("{tmax:.0}"),
        points,
    })
}

/// The map of task `task` of the episode's world: the global path and the driven trajectory (at the submission's
/// scale) over the world's picture (drawn at full scale).
fn map_view(
    sub: &PublicSubmission,
    pic: &WorldPicture,
    (world, task): (u32, u32),
    traj: &[[f64; 6]],
) -> Option<MapView> {
    let t = pic.tasks.get(task as usize)?;
    let s = if sub.scale > 0.0 { sub.scale } else { 1.0 };
    let polyline = |pts: &mut dyn Iterator<Item = (f64, f64)>| {
        let mut o = String::new();
        for (a, c) in pts {
            let _ = write!(o, "{a:.1},{c:.1} ");
        }
        o
    };
    let pair = |(a, c): (f64, f64)| (format!("{a:.1}"), format!("{c:.1}"));
    let ppm = f64::from(pic.ppm);
    Some(MapView {
        width: format!("{:.0}", pic.nx as f64 * ppm),
        height: format!("{:.0}", pic.ny as f64 * ppm),
        image: format!("/worlds/{world}.png"),
        path: polyline(&mut t.path.iter().map(|p| pic.pixel(p[0], p[1]))),
        trajectory: polyline(&mut traj.iter().map(|p| pic.pixel(p[1] / s, p[2] / s))),
        start: pair(pic.pixel(t.start[0], t.start[1])),
        goal: pair(pic.pixel(t.goal[0], t.goal[1])),
    })
}

/// The episode's page; `map`: its world's picture, when the leaderboard serves the task set.
pub fn page(sub: &PublicSubmission, d: &PublicEpisode, map: Option<&WorldPicture>) -> String {
    let r = &d.record;
    let traj = parse_trajectory(&d.trajectory);
    let metrics = r.metrics.as_ref().map(|m| {
        vec![
            format!("{:.1}", m.time),
            format!("{:.1}", m.path_length),
            format!("{:.2}", m.roll_abs.mean),
            format!("{:.1}", m.roll_abs.max),
            format!("{:.2}", m.pitch_abs.mean),
            format!("{:.1}", m.pitch_abs.max),
            format!("{:.1}", m.energy / 1000.0),
            m.obstacle_contacts.to_string(),
            format!("{:.1}", m.final_goal_distance),
        ]
    });
    let opt = |v: &Option<String>| v.clone().unwrap_or_default();
    let chart = |id, title, unit, k: usize| LineChart {
        id,
        title,
        unit,
        plot: plot(&traj.iter().map(|p| (p[0], p[k])).collect::<Vec<_>>()),
    };
    let live = matches!(r.state, EpisodeState::Queued | EpisodeState::Leased);
    render(&Page {
        frame: Frame::served(&r.task_id.to_string(), live),
        back_href: format!("/submissions/{}", sub.id),
        submission_name: sub.name.clone(),
        task: r.task_id,
        world: r.world_id,
        task_index: r.task_index,
        level: r.level.to_string(),
        semantics: r.semantics.to_string(),
        density: r.density.to_string(),
        result: vec![
            ("state", super::submission::state_label(r.state.as_str())),
            (
                "outcome",
                r.outcome.map_or(String::new(), |o| o.as_str().to_string()),
            ),
            ("reason", r.reason.map_or(String::new(), |e| e.to_string())),
            ("detail", opt(&r.detail)),
            ("attempts", r.attempts.to_string()),
            ("planner identity", opt(&r.planner_identity)),
            (
                "simulator",
                opt(&r.sim_version.as_ref().map(|v| v.to_string())),
            ),
            (
                "worker wall time",
                r.wall_time_s.map_or("-".into(), |t| format!("{t:.2} s")),
            ),
        ],
        metrics,
        map: map.and_then(|m| map_view(sub, m, (r.world_id, r.task_index), &traj)),
        charts: vec![
            chart("roll-chart", "roll", "°", 3),
            chart("pitch-chart", "pitch", "°", 4),
            chart("speed-chart", "speed", "m/s", 5),
        ],
        submission_id: sub.id.clone(),
    })
}
