//! Files of an evaluation: `episodes.csv`, `summary.json`, `summary.txt`, `charts.svg`; and a static leaderboard
//! page over several evaluations.

use crate::summary::{Aggregate, Summary};
use crate::{io_err, EpisodeRow, EvalError};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// One CSV row per episode with every metric.
pub fn episodes_csv(rows: &[EpisodeRow]) -> String {
    let mut s = String::from(
        "task_id,world_id,task_index,level,semantics,density,planner,vehicle,scale,seed,task_set_version,sim_version,outcome,reason,time_s,roll_mean_deg,roll_var,roll_max,roll_abs_mean_deg,roll_abs_var,roll_abs_max,pitch_mean_deg,pitch_var,pitch_max,pitch_abs_mean_deg,pitch_abs_var,pitch_abs_max,throttle_mean,throttle_var,throttle_tv,steering_mean,steering_var,steering_tv,path_length_m,energy_j,obstacle_contacts,final_goal_distance_m,steps,wall_time_s\n",
    );
    for r in rows {
        let m = &r.metrics;
        let _ = writeln!(
            s,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.3},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.3},{:.1},{},{:.3},{},{:.4}",
            r.task_id, r.world_id, r.task_index, r.level, r.semantics, r.density, r.planner, r.vehicle, r.scale, r.seed,
            r.task_set_version, r.sim_version, r.outcome, r.reason, m.time, m.roll.mean, m.roll.var, m.roll.max,
            m.roll_abs.mean, m.roll_abs.var, m.roll_abs.max, m.pitch.mean, m.pitch.var, m.pitch.max, m.pitch_abs.mean,
            m.pitch_abs.var, m.pitch_abs.max, m.throttle_mean, m.throttle_var, m.throttle_tv, m.steering_mean,
            m.steering_var, m.steering_tv, m.path_length, m.energy, m.obstacle_contacts, m.final_goal_distance, m.steps,
            r.wall_time_s
        );
    }
    s
}

fn line(name: &str, a: &Aggregate) -> String {
    format!(
        "{name:<12} {:>5} {:>6.1}% [{:>5.1}, {:>5.1}] {:>7.1} {:>6.2} {:>6.2} {:>7.1}% {:>6.1}% {:>7.1}% {:>7.1}%\n",
        a.episodes,
        100.0 * a.success_rate,
        100.0 * a.success_ci95.0,
        100.0 * a.success_ci95.1,
        a.traversal_time_mean,
        a.roll_mean,
        a.pitch_mean,
        a.rollover_pct,
        a.stuck_pct,
        a.timeout_pct,
        a.off_map_pct + a.planner_failure_pct
    )
}

/// Human-readable summary table.
pub fn summary_text(s: &Summary) -> String {
    let mut t = format!(
        "planner {} | vehicle {} (scale {}) | task set {} | {}\n",
        s.planner, s.vehicle, s.scale, s.task_set_version, s.sim_version
    );
    t += "group        tasks success  [95% CI]      time_s  roll   pitch  rollover  stuck  timeout  other\n";
    t += &line("overall", &s.overall);
    for (title, map) in [
        ("elevation", &s.by_level),
        ("semantics", &s.by_semantics),
        ("obstacles", &s.by_density),
    ] {
        t += &format!("-- {title}\n");
        for (k, a) in map.iter() {
            t += &line(k, a);
        }
    }
    t
}

/// SVG bar charts of the success rate (with its interval) by elevation, semantics and obstacle density.
pub fn charts_svg(s: &Summary) -> String {
    let groups: [(&str, &BTreeMap<String, Aggregate>); 3] = [
        ("elevation level", &s.by_level),
        ("terrain semantics", &s.by_semantics),
        ("obstacle density", &s.by_density),
    ];
    let (w, h, pad) = (900.0, 320.0, 40.0);
    let mut svg = format!("<svg xmlns='http://www.w3.org/2000/svg' width='{w}' height='{h}' font-family='sans-serif' font-size='12'>\n");
    let _ = writeln!(
        svg,
        "<text x='10' y='18' font-size='14'>success rate of {} (95% CI)</text>",
        s.planner
    );
    let panel = (w - pad) / 3.0;
    for (gi, (title, map)) in groups.iter().enumerate() {
        let x0 = pad / 2.0 + gi as f64 * panel;
        let _ = writeln!(
            svg,
            "<text x='{:.0}' y='{:.0}'>{title}</text>",
            x0 + 10.0,
            h - 8.0
        );
        let n = map.len().max(1) as f64;
        let bw = (panel - 40.0) / n;
        for (k, (name, a)) in map.iter().enumerate() {
            let bx = x0 + 20.0 + k as f64 * bw;
            let plot_h = h - 90.0;
            let y = |v: f64| 40.0 + plot_h * (1.0 - v);
            let _ = writeln!(
                svg,
                "<rect x='{:.1}' y='{:.1}' width='{:.1}' height='{:.1}' fill='#4a7fb5'/>",
                bx + 4.0,
                y(a.success_rate),
                bw - 8.0,
                plot_h * a.success_rate
            );
            let cx = bx + bw / 2.0;
            let _ = writeln!(
                svg,
                "<line x1='{cx:.1}' x2='{cx:.1}' y1='{:.1}' y2='{:.1}' stroke='black'/>",
                y(a.success_ci95.0),
                y(a.success_ci95.1)
            );
            let _ = writeln!(
                svg,
                "<text x='{:.1}' y='{:.1}' text-anchor='middle'>{name}</text>",
                cx,
                h - 30.0
            );
            let _ = writeln!(
                svg,
                "<text x='{:.1}' y='{:.1}' text-anchor='middle'>{:.0}%</text>",
                cx,
                y(a.success_rate) - 4.0,
                100.0 * a.success_rate
            );
        }
    }
    svg + "</svg>\n"
}

/// Writes every file of an evaluation into `dir`.
pub fn write(dir: &Path, rows: &[EpisodeRow], s: &Summary) -> Result<(), EvalError> {
    let files = [
        ("episodes.csv", episodes_csv(rows)),
        (
            "summary.json",
            serde_json::to_string_pretty(s).map_err(|e| io_err(dir, e))? + "\n",
        ),
        ("summary.txt", summary_text(s)),
        ("charts.svg", charts_svg(s)),
    ];
    for (name, text) in files {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|e| io_err(&p, e))?;
    }
    Ok(())
}

/// A static leaderboard page ranking evaluations by success rate, with their breakdowns.
pub fn leaderboard_html(summaries: &[Summary]) -> String {
    let mut ranked: Vec<&Summary> = summaries.iter().collect();
    ranked.sort_by(|a, b| b.overall.success_rate.total_cmp(&a.overall.success_rate));
    let mut h = String::from("<!doctype html><html><head><meta charset='utf-8'><title>vertibench leaderboard</title><style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:4px 8px;text-align:right}th{background:#eee}</style></head><body><h1>vertibench leaderboard</h1>\n<table><tr><th>rank</th><th>planner</th><th>vehicle</th><th>tasks</th><th>success</th><th>95% CI</th><th>time (s)</th><th>roll</th><th>pitch</th><th>rollover</th><th>stuck</th><th>timeout</th><th>low / medium / high</th><th>rigid / deformable / mixed</th><th>sparse / medium / dense</th><th>task set</th><th>simulator</th></tr>\n");
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
    for (i, s) in ranked.iter().enumerate() {
        let a = &s.overall;
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.1}%</td><td>[{:.1}, {:.1}]</td><td>{:.1}</td><td>{:.2}</td><td>{:.2}</td><td>{:.1}%</td><td>{:.1}%</td><td>{:.1}%</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            i + 1, s.planner, s.vehicle, a.episodes, 100.0 * a.success_rate, 100.0 * a.success_ci95.0, 100.0 * a.success_ci95.1,
            a.traversal_time_mean, a.roll_mean, a.pitch_mean, a.rollover_pct, a.stuck_pct, a.timeout_pct,
            trio(&s.by_level, ["low", "medium", "high"]), trio(&s.by_semantics, ["rigid", "deformable", "mixed"]),
            trio(&s.by_density, ["sparse", "medium", "dense"]), s.task_set_version, s.sim_version
        );
    }
    h + "</table></body></html>\n"
}
