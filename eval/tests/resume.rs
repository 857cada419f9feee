//! An interrupted evaluation resumes where it stopped; nothing is counted twice; bad input gets clear errors.

use eval::{run, EvalConfig};
use sim_core::episode::EpisodeConfig;
use std::path::Path;

fn cfg(out: &Path, tasks: &str) -> EvalConfig {
    EvalConfig {
        planner: "pid".into(),
        identity: None,
        task_dir: tasks::TaskSet::default_dir(),
        tasks: tasks.into(),
        vehicle: "hmmwv".into(),
        scale: None,
        out: out.to_path_buf(),
        out_param: "--out".into(),
        episode: EpisodeConfig {
            max_time: 20.0,
            ..Default::default()
        },
        perception: perception::Profile::ideal(),
    }
}

#[test]
fn a_resumed_evaluation_equals_an_uninterrupted_one() {
    let base = std::env::temp_dir().join(format!("vb-resume-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&base);
    let (a, b) = (base.join("a"), base.join("b"));
    let full = run(&cfg(&a, "3,w004-t1,w004-t7"), &|_, _, _| {}).unwrap();
    assert_eq!(full.len(), 12);
    // "Interrupt" b after part of the work, leaving a torn last line as a crash would.
    run(&cfg(&b, "3"), &|_, _, _| {}).unwrap();
    let log = b.join("results.jsonl");
    let mut text = std::fs::read_to_string(&log).unwrap();
    text.push_str("{\"task_id\":\"w004-t1\",\"wor");
    std::fs::write(&log, text).unwrap();
    let mut calls = 0usize;
    let counter = std::sync::Mutex::new(&mut calls);
    let resumed = run(&cfg(&b, "3,w004-t1,w004-t7"), &|_, _, _| {
        **counter.lock().unwrap() += 1
    })
    .unwrap();
    assert_eq!(calls, 2, "only the two missing episodes ran");
    let key = |rows: &[eval::EpisodeRow]| {
        rows.iter()
            .map(|r| (r.task_id, r.outcome, r.metrics.time.to_bits()))
            .collect::<Vec<_>>()
    };
    assert_eq!(
        key(&resumed),
        key(&full),
        "same episodes, same results, no duplicates"
    );
    // Running again does nothing and still reports every episode once.
    let again = run(&cfg(&b, "3,w004-t1,w004-t7"), &|_, _, _| {
        panic!("nothing left to run")
    })
    .unwrap();
    assert_eq!(again.len(), 12);
    std::fs::remove_dir_all(&base).unwrap();
}

#[test]
fn bad_parameters_get_clear_errors() {
    let out = std::env::temp_dir().join(format!("vb-bad-{}", std::process::id()));
    let mut c = cfg(&out, "w999-t1");
    let e = run(&c, &|_, _, _| {}).unwrap_err().to_string();
    assert!(
        e.contains("w999-t1") && e.contains("not in the task set"),
        "{e}"
    );
    c.tasks = "banana".into();
    assert!(run(&c, &|_, _, _| {})
        .unwrap_err()
        .to_string()
        .contains("banana"));
    c.tasks = "1".into();
    c.planner = "teleport".into();
    assert!(run(&c, &|_, _, _| {})
        .unwrap_err()
        .to_string()
        .contains("unknown planner `teleport`"));
    c.planner = "pid".into();
    c.vehicle = "spaceship".into();
    assert!(run(&c, &|_, _, _| {})
        .unwrap_err()
        .to_string()
        .contains("unknown vehicle `spaceship`"));
}

#[test]
fn results_of_another_physics_revision_are_never_resumed() {
    let out = std::env::temp_dir().join(format!("vb-simver-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let c = cfg(&out, "w004-t1");
    let rows = run(&c, &|_, _, _| {}).unwrap();
    assert_eq!(rows[0].sim_version, eval::SIM_VERSION);
    // The same directory as if an older sim-core had written it.
    let log = out.join("results.jsonl");
    let text = std::fs::read_to_string(&log).unwrap();
    let old = text.replace(eval::SIM_VERSION, "sim-core 0.1.0");
    assert_ne!(old, text);
    std::fs::write(&log, &old).unwrap();
    let e = run(&cfg(&out, "w004-t1,w004-t2"), &|_, _, _| {
        panic!("no episode may run into another revision's results")
    })
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("sim-core 0.1.0") && e.contains("use another --out"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(&log).unwrap(),
        old,
        "nothing appended"
    );
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn results_of_other_rules_are_never_resumed() {
    let out = std::env::temp_dir().join(format!("vb-rules-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let paper = EvalConfig {
        episode: EpisodeConfig::default(),
        ..cfg(&out, "w001-t0")
    };
    let rows = run(&paper, &|_, _, _| {}).unwrap();
    assert_eq!(rows[0].rules, sim_core::episode::Rules::Paper);
    assert_eq!(
        eval::summary::summarise(&rows).rules,
        sim_core::episode::Rules::Paper
    );
    let release = EvalConfig {
        episode: EpisodeConfig::release(),
        ..cfg(&out, "w001-t0")
    };
    let e = run(&release, &|_, _, _| {}).unwrap_err().to_string();
    assert!(e.contains("paper rules"), "{e}");
    assert_eq!(
        EpisodeConfig::release().rules(),
        sim_core::episode::Rules::Release
    );
    assert_eq!(
        cfg(&out, "1").episode.rules(),
        sim_core::episode::Rules::Custom
    );
}
