//! Tables and charts list a factor's levels in their natural order (low, medium, high), not alphabetically.

use eval::EpisodeRow;
use sim_core::episode::EpisodeMetrics;

fn row(task: &str, level: &str, semantics: &str, density: &str) -> EpisodeRow {
    EpisodeRow {
        task_id: task.parse().unwrap(),
        world_id: 1,
        task_index: 0,
        level: level.parse().unwrap(),
        semantics: semantics.parse().unwrap(),
        density: density.parse().unwrap(),
        terrain: None,
        planner: "p".into(),
        vehicle: "hmmwv".into(),
        scale: 1.0,
        seed: 0,
        task_set_version: "v".into(),
        sim_version: "s".into(),
        rules: Default::default(),
        perception: Default::default(),
        outcome: "success".parse().unwrap(),
        reason: "success".parse().unwrap(),
        detail: String::new(),
        metrics: EpisodeMetrics::default(),
        wall_time_s: 0.1,
    }
}

#[test]
fn levels_come_in_their_natural_order() {
    let rows = vec![
        row("w001-t0", "high", "mixed", "dense"),
        row("w002-t0", "low", "rigid", "sparse"),
        row("w003-t0", "medium", "deformable", "medium"),
    ];
    let s = eval::summary::summarise(&rows);
    let text = eval::report::summary_text(&s);
    let svg = eval::charts::charts_svg(&s).into_string();
    for (doc, what) in [(&text, "summary.txt"), (&svg, "charts.svg")] {
        let at = |w: &str| doc.find(w).unwrap_or_else(|| panic!("{what} lacks {w}"));
        assert!(
            at("low") < at("medium") && at("medium") < at("high"),
            "{what}"
        );
        assert!(
            at("rigid") < at("deformable") && at("deformable") < at("mixed"),
            "{what}"
        );
        assert!(at("sparse") < at("dense"), "{what}");
    }
}
