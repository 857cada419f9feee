//! An evaluation resumes only with the planner that wrote its results (`planner.json`); a cancelled evaluation
//! stops its running episodes and keeps what finished.

use eval::{prepare, run, EvalConfig, PlannerIdentity, PlannerSource, IDENTITY_FILE};
use sim_core::episode::EpisodeConfig;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

fn cfg(out: &Path, tasks: &str) -> EvalConfig {
    EvalConfig {
        planner: "pid".into(),
        identity: None,
        task_dir: tasks::TaskSet::default_dir(),
        tasks: tasks.into(),
        vehicle: "hmmwv".into(),
        scale: None,
        out: out.to_path_buf(),
        out_param: "out=".into(),
        episode: EpisodeConfig {
            max_time: 20.0,
            ..Default::default()
        },
        perception: perception::Profile::ideal(),
    }
}

fn fresh(name: &str) -> PathBuf {
    let out = std::env::temp_dir().join(format!("vb-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    out
}

fn python(name: &str, params: &str) -> PlannerIdentity {
    PlannerIdentity {
        kind: PlannerSource::Python,
        name: name.into(),
        class: Some("my_planners.Follow".into()),
        version: None,
        params_sha256: Some(params.into()),
        params: None,
    }
}

#[test]
fn another_planner_under_the_same_label_is_refused_and_an_old_directory_resumes() {
    let out = fresh("identity");
    run(&cfg(&out, "w001-t0"), &|_, _, _| {}).unwrap();
    let stored = std::fs::read_to_string(out.join(IDENTITY_FILE)).unwrap();
    assert!(
        stored.contains("\"builtin\"") && stored.contains("\"pid\""),
        "{stored}"
    );
    // The rows' label is the same; the planner is not.
    let other = EvalConfig {
        identity: Some(python("pid", "abcdef0123456789")),
        ..cfg(&out, "w001-t0,w001-t1")
    };
    let e = prepare(&other).err().unwrap().to_string();
    assert!(
        e.contains("built-in pid, not python planner \"pid\" of class my_planners.Follow")
            && e.contains("abcdef012345")
            && e.contains("use another out="),
        "{e}"
    );
    // A directory written before `planner.json` existed resumes (its rows are checked) and gets one.
    std::fs::remove_file(out.join(IDENTITY_FILE)).unwrap();
    let resumed = cfg(&out, "w001-t0,w001-t1");
    let p = prepare(&resumed).unwrap();
    assert_eq!((p.kept(), p.total()), (1, 2));
    assert!(out.join(IDENTITY_FILE).is_file());
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn the_parameters_that_differ_are_named() {
    let mut a = python("follow", "1111");
    let mut b = python("follow", "2222");
    let params = |gain: f64| {
        serde_json::json!({"gain": gain, "horizon": 10})
            .as_object()
            .cloned()
    };
    a.params = params(1.0);
    b.params = params(2.5);
    assert!(!a.same(&b) && a.same(&a.clone()));
    let d = a.difference(&b);
    assert!(d.contains("parameters that differ: gain 1.0 -> 2.5"), "{d}");
    assert!(!d.contains("horizon"), "{d}");
}

/// Stops the evaluation it runs in once it has acted `after` times.
struct Cancels {
    acted: usize,
    after: usize,
}

static CANCEL: AtomicBool = AtomicBool::new(false);
static ACTED_AFTER_CANCEL: AtomicUsize = AtomicUsize::new(0);

impl Planner for Cancels {
    fn name(&self) -> &str {
        "cancels"
    }
    fn control_rate_hz(&self) -> f64 {
        10.0
    }
    fn reset(&mut self, _: &PlannerContext<'_>) -> Result<(), PlannerError> {
        Ok(())
    }
    fn act(&mut self, _: &Observation) -> Result<Action, PlannerError> {
        if CANCEL.load(Ordering::SeqCst) {
            ACTED_AFTER_CANCEL.fetch_add(1, Ordering::SeqCst);
        }
        self.acted += 1;
        if self.acted == self.after {
            CANCEL.store(true, Ordering::SeqCst);
        }
        Ok(Action::default())
    }
}

#[test]
fn a_cancelled_evaluation_stops_its_running_episode_and_keeps_what_finished() {
    let out = fresh("cancel");
    let mut c = cfg(&out, "w001-t0,w001-t1,w001-t2");
    c.planner = "cancels".into();
    c.identity = Some(python("cancels", "00"));
    // Standing still, each episode lasts until `max_time` (20 s, 200 actions) unless cancelled.
    let episodes = AtomicUsize::new(0);
    let make = || -> Box<dyn Planner> {
        let n = episodes.fetch_add(1, Ordering::SeqCst);
        Box::new(Cancels {
            acted: 0,
            after: if n == 1 { 5 } else { usize::MAX },
        })
    };
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let rows = pool
        .install(|| eval::run_with(&c, &make, &CANCEL, &|_, _, _| {}))
        .unwrap();
    assert_eq!(
        rows.len(),
        1,
        "the first episode finished, the second was cancelled"
    );
    assert_eq!(
        episodes.load(Ordering::SeqCst),
        2,
        "no episode started after"
    );
    assert_eq!(
        ACTED_AFTER_CANCEL.load(Ordering::SeqCst),
        0,
        "the running episode stopped at its next control step"
    );
    let lines = std::fs::read_to_string(out.join("results.jsonl")).unwrap();
    assert_eq!(lines.lines().count(), 1);
    std::fs::remove_dir_all(&out).unwrap();
}
