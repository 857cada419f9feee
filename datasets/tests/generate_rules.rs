//! The generators' rules that need no long run: the shared names, the training-set rule, option checks and the
//! vehicles' wheel counts.

use anyhow::Result;
use datasets::generate::source::BENCHMARK_TASK_SET_VERSION;
use datasets::generate::*;
use datasets::record::{GOAL_FIELDS, STATE_FIELDS};
use datasets::{DatasetKind, SpeedProfile};
use sim_core::world::{Heightmap, Semantic, Surface, World};
use tasks::TaskSet;

mod gen_support;
use gen_support::{config, PERIOD};

#[test]
fn shared_names_and_the_benchmark_version() -> Result<()> {
    assert_eq!(STATE_FIELDS, sim_core::observe::STATE_FIELDS);
    assert_eq!(GOAL_FIELDS, sim_core::observe::GOAL_FIELDS);
    assert_eq!(TaskSet::committed()?.version(), BENCHMARK_TASK_SET_VERSION);
    assert_eq!(episode_index(5, episode_seed(5, 123_456)), 123_456);
    Ok(())
}

#[test]
fn the_benchmark_set_is_refused_unless_allowed_and_then_marked() -> Result<()> {
    let mut cfg = GenerateConfig::new(DatasetKind::Random, TaskSet::default_dir(), 1.0);
    let err = spec(&cfg).expect_err("refused").to_string();
    assert!(
        err.contains("vb tasks generate --seed 7") && err.contains("--allow-benchmark-tasks"),
        "{err}"
    );
    let mut sink = Vec::new();
    assert!(matches!(
        run(&cfg, &Resume::default(), &mut sink, None, &|_| {}),
        Err(GenerateError::BenchmarkTasks(_))
    ));
    cfg.allow_benchmark_tasks = true;
    let s = spec(&cfg)?;
    assert!(s.analysis_only && s.task_set_version == BENCHMARK_TASK_SET_VERSION);
    // A training set is not analysis-only, flag or not.
    let mut cfg = config(DatasetKind::Random, 1.0);
    cfg.allow_benchmark_tasks = true;
    let s = spec(&cfg)?;
    assert!(!s.analysis_only && s.task_set_seed == Some(7) && s.wheels == 4 && s.seed == 11);
    assert!((s.control_rate_hz - 1.0 / PERIOD).abs() < 1e-9);
    // The paper's profile is left out of info.json (datasets made before the field read the same); stop-and-go
    // is written, and read back.
    assert!(!serde_json::to_string(&s)?.contains("speed_profile"));
    cfg.speed_profile = SpeedProfile::StopAndGo;
    let s = spec(&cfg)?;
    let json = serde_json::to_string(&s)?;
    assert!(json.contains(r#""speed_profile":"stop_and_go""#), "{json}");
    assert_eq!(serde_json::from_str::<datasets::DatasetSpec>(&json)?, s);
    cfg.speed_profile = SpeedProfile::Fast;
    let s = spec(&cfg)?;
    let json = serde_json::to_string(&s)?;
    assert!(json.contains(r#""speed_profile":"fast""#), "{json}");
    assert_eq!(serde_json::from_str::<datasets::DatasetSpec>(&json)?, s);
    Ok(())
}

#[test]
fn bad_options_are_refused_with_their_name() -> Result<()> {
    let bad = |f: &dyn Fn(&mut GenerateConfig), field: &str| {
        let mut cfg = config(DatasetKind::Expert, 1.0);
        f(&mut cfg);
        let e = spec(&cfg).expect_err("refused").to_string();
        assert!(e.contains(field), "{e}");
    };
    bad(&|c| c.hours = 0.0, "hours");
    bad(&|c| c.hours = f64::NAN, "hours");
    bad(&|c| c.planners = vec!["astar".into()], "planners");
    bad(
        &|c| c.planners = vec!["pid".into(), "eh".into()],
        "planners",
    );
    bad(&|c| c.control_rate_hz = 10.0, "control_rate_hz");
    bad(&|c| c.crop_size = 0, "crop_size");
    bad(&|c| c.scale = Some(2.0), "scale");
    bad(&|c| c.vehicle = "tank".into(), "tank");
    for profile in [SpeedProfile::StopAndGo, SpeedProfile::Fast] {
        bad(&|c| c.speed_profile = profile, "speed_profile");
    }
    let cfg = config(DatasetKind::Failures, 1.0);
    let (mut a, mut b) = (Vec::new(), Vec::new());
    let e = run(&cfg, &Resume::default(), &mut a, Some(&mut b), &|_| {}).expect_err("refused");
    assert!(e.to_string().contains("failures"), "{e}");
    Ok(())
}

#[test]
fn contact_count_is_the_simulators() -> Result<()> {
    let flat = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    );
    for v in sim_core::vehicle::builtin_vehicles() {
        let sim = sim_core::Simulation::new(&flat, &v, 0.0, 0.0, 0.0);
        assert_eq!(contact_count(&v), sim.wheels().count(), "{}", v.name);
    }
    Ok(())
}
