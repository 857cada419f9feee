//! `vb eval` runs learned policies (issue 33): a weights file given with `--weights` under a name of one's choice,
//! its identity (the file's SHA-256) kept in `planner.json` so another file cannot resume the evaluation; a file of
//! another layout, a classical baseline with weights and a learned name this build has no weights for are refused
//! with messages that say what to do.

use integration::*;
use learned::weights::{layout_metadata, untrained};
use std::process::Command;

#[test]
fn vb_eval_runs_a_weights_file_and_keeps_its_identity() {
    let dir = temp_dir("learned-eval");
    let a = dir.join("a.safetensors");
    let b = dir.join("b.safetensors");
    std::fs::write(&a, untrained(1, 16, layout_metadata("mine", 20.0, "hmmwv"))).unwrap();
    std::fs::write(&b, untrained(2, 16, layout_metadata("mine", 20.0, "hmmwv"))).unwrap();
    let out = dir.join("eval");
    let (a_s, out_s) = (a.display().to_string(), out.display().to_string());
    let args = [
        "eval",
        "--planner",
        "mine",
        "--weights",
        &a_s,
        "--tasks",
        "w001-t0,w002-t1",
        "--out",
        &out_s,
    ];
    vb_run(&args);
    let rows = std::fs::read_to_string(out.join("results.jsonl")).unwrap();
    assert_eq!(rows.lines().count(), 2, "{rows}");
    assert!(
        rows.lines().all(|l| l.contains("\"planner\":\"mine\"")),
        "{rows}"
    );
    let identity = std::fs::read_to_string(out.join("planner.json")).unwrap();
    let net = learned::PolicyNet::from_bytes(&std::fs::read(&a).unwrap()).unwrap();
    assert!(identity.contains(net.sha256()), "{identity}");
    // The same file resumes (nothing to do); another file under the same name is refused.
    vb_run(&args);
    let b_s = b.display().to_string();
    let refused = Command::new(vb())
        .args([
            "eval",
            "--planner",
            "mine",
            "--weights",
            &b_s,
            "--tasks",
            "w001-t0",
            "--out",
            &out_s,
        ])
        .output()
        .expect("run vb");
    assert!(
        !refused.status.success(),
        "another weights file resumed the evaluation"
    );
    let e = String::from_utf8_lossy(&refused.stderr);
    assert!(e.contains(net.sha256()), "{e}");
}

#[test]
fn wrong_weights_and_unavailable_learned_planners_are_refused_with_what_to_do() {
    let dir = temp_dir("learned-refused");
    let bad = dir.join("v0.safetensors");
    let mut meta = layout_metadata("mine", 20.0, "hmmwv");
    meta.insert("features".into(), "goal_cos,goal_sin".into());
    std::fs::write(&bad, untrained(1, 8, meta)).unwrap();
    let bad_s = bad.display().to_string();
    let missing = dir.join("missing.safetensors").display().to_string();
    let out = dir.join("out").display().to_string();
    let eval = |planner: &str, weights: Option<&str>| {
        let mut args = vec![
            "eval",
            "--planner",
            planner,
            "--tasks",
            "w001-t0",
            "--out",
            &out,
        ];
        if let Some(w) = weights {
            args.extend(["--weights", w]);
        }
        Command::new(vb()).args(&args).output().expect("run vb")
    };
    let fails = |planner: &str, weights: Option<&str>| {
        let o = eval(planner, weights);
        assert!(!o.status.success(), "vb eval --planner {planner} succeeded");
        String::from_utf8_lossy(&o.stderr).to_string()
    };
    let e = fails("mine", Some(&bad_s));
    assert!(
        e.contains("features") && e.contains("goal_cos,goal_sin"),
        "{e}"
    );
    let e = fails("pid", Some(&bad_s));
    assert!(e.contains("classical baseline"), "{e}");
    let e = fails("rl", Some(&missing));
    assert!(e.contains("missing.safetensors"), "{e}");
    let e = fails("nope", None);
    assert!(
        e.contains("unknown planner `nope`") && e.contains("pid"),
        "{e}"
    );
    // A learned name runs its compiled-in weights, or says how to make them.
    for name in learned::NAMES {
        if learned::builtin::available().contains(&name) {
            let o = eval(name, None);
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            std::fs::remove_dir_all(&out).unwrap();
        } else {
            let e = fails(name, None);
            let how = if ["mppi6", "wmvct", "tal", "tnt"].contains(&name) {
                "vertibench.kino train"
            } else {
                "vertibench.train"
            };
            assert!(
                e.contains("no weights in this build") && e.contains(how),
                "{e}"
            );
        }
    }
}
