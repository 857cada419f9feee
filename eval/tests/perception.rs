//! Evaluations under a perception profile: rows carry the profile, a directory of another profile is never
//! resumed, `ideal` rows are those of a run without the layer (the field omitted), the noise is the same at any
//! thread count, and a planner that reads the ground-truth maps is refused by a profile that degrades them.

use eval::{run, EvalConfig};
use sim_core::episode::EpisodeConfig;
use std::path::Path;

fn cfg(out: &Path, planner: &str, profile: &str) -> EvalConfig {
    EvalConfig {
        planner: planner.into(),
        identity: None,
        task_dir: tasks::TaskSet::default_dir(),
        tasks: "w001-t0,w002-t3,w040-t1,w077-t5".into(),
        vehicle: "hmmwv".into(),
        scale: None,
        out: out.to_path_buf(),
        out_param: "--out".into(),
        episode: EpisodeConfig {
            max_time: 15.0,
            ..Default::default()
        },
        perception: eval::perception_profile(profile).unwrap(),
    }
}

fn temp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("vb-perception-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn in_pool<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
        .install(f)
}

/// Degraded state estimation and actuation change what PID does, identically on one thread and on four, and the
/// rows say under which profile they ran.
#[test]
fn a_profile_changes_the_run_the_same_at_any_thread_count() {
    let (ideal_dir, one, four) = (temp("ideal"), temp("one"), temp("four"));
    let ideal = run(&cfg(&ideal_dir, "pid", "ideal"), &|_, _, _| {}).unwrap();
    let a = in_pool(1, || {
        run(&cfg(&one, "pid", "degraded"), &|_, _, _| {}).unwrap()
    });
    let b = in_pool(4, || {
        run(&cfg(&four, "pid", "degraded"), &|_, _, _| {}).unwrap()
    });
    let strip = |rows: &[eval::EpisodeRow]| {
        rows.iter()
            .map(|r| (r.task_id, r.outcome, r.metrics.clone()))
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&a), strip(&b));
    assert_ne!(
        strip(&a),
        strip(&ideal),
        "degraded perception changed nothing"
    );
    let id = eval::perception_profile("degraded").unwrap().id();
    assert!(a.iter().all(|r| r.perception == id));
    assert!(ideal.iter().all(|r| r.perception.is_ideal()));
    // Ideal rows omit the field: they read as rows always have.
    let text = std::fs::read_to_string(ideal_dir.join("results.jsonl")).unwrap();
    assert!(!text.contains("perception"), "{text}");
    let text = std::fs::read_to_string(one.join("results.jsonl")).unwrap();
    assert!(text.contains(&format!("\"perception\":\"{id}\"")));
    assert_eq!(eval::summary::summarise(&a).perception, id);
    for d in [ideal_dir, one, four] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

/// A directory written under one profile refuses to resume under another (nothing appended), and a parameter
/// changed in a profile file is another profile.
#[test]
fn results_of_another_profile_are_never_resumed() {
    let out = temp("resume");
    run(&cfg(&out, "pid", "nominal"), &|_, _, _| {}).unwrap();
    let log = out.join("results.jsonl");
    let before = std::fs::read_to_string(&log).unwrap();
    let e = run(&cfg(&out, "pid", "degraded"), &|_, _, _| {
        panic!("no episode may run into another profile's results")
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("perception nominal@") && e.contains("use another --out"),
        "{e}"
    );
    let file = out.join("nominal.toml");
    let text = include_str!("../../perception/profiles/nominal.toml")
        .replace("position_sigma = 0.05", "position_sigma = 0.06");
    std::fs::write(&file, text).unwrap();
    let changed = cfg(&out, "pid", file.to_str().unwrap());
    assert_eq!(changed.perception.name, "nominal");
    let e = run(&changed, &|_, _, _| {}).unwrap_err().to_string();
    assert!(e.contains("perception nominal@"), "{e}");
    assert_eq!(
        std::fs::read_to_string(&log).unwrap(),
        before,
        "nothing appended"
    );
    std::fs::remove_dir_all(&out).unwrap();
}

/// MPPI-6 (the oracle) simulates the world's heights from its context and not the believed world: a profile that
/// degrades the maps refuses it with the reason, one that degrades only the state does not (shown with EH); an unknown profile is a
/// clear error.
#[test]
fn map_reading_planners_are_refused_by_map_degrading_profiles() {
    let out = temp("mppi6");
    let e = run(&cfg(&out, "mppi6-oracle", "nominal"), &|_, _, _| {})
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("ground-truth maps") && e.contains("nominal"),
        "{e}"
    );
    let state_only = temp("eh-state");
    let file = state_only.with_extension("toml");
    std::fs::write(&file, "[state]\nposition_sigma = 0.2\n").unwrap();
    let rows = run(
        &cfg(&state_only, "eh", file.to_str().unwrap()),
        &|_, _, _| {},
    )
    .unwrap();
    assert_eq!(rows.len(), 4);
    let e = eval::perception_profile("foggy").unwrap_err().to_string();
    assert!(e.contains("unknown perception profile `foggy`"), "{e}");
    for d in [out, state_only] {
        let _ = std::fs::remove_dir_all(d);
    }
    let _ = std::fs::remove_file(file);
}

/// The elevation heuristic reads the believed map its observations carry: under `nominal` it runs, and what it
/// saw (unknown regions skipped, the map built as it drives) changes its episodes from those under the truth.
#[test]
fn the_elevation_heuristic_drives_on_what_it_has_seen() {
    let (ideal_dir, nominal_dir) = (temp("eh-ideal"), temp("eh-nominal"));
    let ideal = run(&cfg(&ideal_dir, "eh", "ideal"), &|_, _, _| {}).unwrap();
    let nominal = run(&cfg(&nominal_dir, "eh", "nominal"), &|_, _, _| {}).unwrap();
    assert_eq!(nominal.len(), 4);
    let path = |rows: &[eval::EpisodeRow]| {
        rows.iter()
            .map(|r| r.metrics.path_length)
            .collect::<Vec<_>>()
    };
    assert_ne!(path(&ideal), path(&nominal));
    for d in [ideal_dir, nominal_dir] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
