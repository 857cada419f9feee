//! One results format: `vb-submit results ID --out DIR` writes what `vb eval` writes, equal to a local `vb eval` of
//! the same planner on the same tasks (apart from wall times), so `vb compare` and `vb leaderboard-static` take
//! service and local runs alike. Real processes: `vb coordinator`, `vb worker`, the `vb-submit` and `vb` CLIs.

use integration::*;
use std::path::Path;
use std::process::Command;
use std::time::Duration;
use vb_proto::v1 as pb;

/// Runs a command to its successful end; its stdout.
fn run_command(mut c: Command) -> String {
    let out = c.output().expect("running a CLI");
    assert!(
        out.status.success(),
        "{c:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `episodes.csv` as (header, rows) with the wall-time column blanked.
fn csv_without_wall_time(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines
        .next()
        .expect("a header")
        .split(',')
        .map(str::to_string)
        .collect();
    let wall = header.iter().position(|h| h == "wall_time_s");
    let rows = lines
        .map(|l| {
            let mut cells: Vec<String> = l.split(',').map(str::to_string).collect();
            if let Some(w) = wall {
                cells[w].clear();
            }
            cells
        })
        .collect();
    (header, rows)
}

/// `summary.json` without the wall-clock fields (the only ones a service run and a local run may differ in).
fn summary_without_wall_time(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut v: serde_json::Value = serde_json::from_str(&text).expect("summary.json");
    if let Some(o) = v.as_object_mut() {
        o.retain(|k, _| !k.contains("wall"));
    }
    v
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn service_results_are_vb_evals_files() -> anyhow::Result<()> {
    let dir = temp_dir("results-format");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker(&dir, "worker", &db, port, 2);
    let mut c = client(port, &token).await;
    // The submission is named as vb eval names its planner, so every column but the wall time can be equal.
    let req = pb::SubmitRequest {
        name: "pid".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Builtin("pid".into())),
        }),
        task_ids: (0..10).map(|t| format!("w001-t{t}")).collect(),
        ..Default::default()
    };
    let id = vb_submit::submit(&mut c, req).await?.submission_id;
    let done = wait_for(port, &token, &id, Duration::from_secs(300), |s| {
        s.state() == pb::SubmissionState::Done
    })
    .await;
    assert_eq!((done.finished, done.total), (10, 10));

    let service = dir.join("service");
    let url = format!("http://127.0.0.1:{port}");
    // `vb-submit results ID ARGS...` against this coordinator.
    let results = |args: &[&str]| {
        let mut c = Command::new(vb_submit_bin());
        c.args(["--coordinator", &url, "--token", &token, "results", &id]);
        c.args(args);
        c
    };
    let out = run_command(results(&["--out", service.to_str().unwrap()]));
    assert!(
        out.contains("success"),
        "it prints vb eval's summary: {out}"
    );
    let local = dir.join("local");
    vb_run(&[
        "eval",
        "--planner",
        "pid",
        "--tasks",
        "1",
        "--threads",
        "1",
        "--out",
        local.to_str().unwrap(),
    ]);
    for f in [
        "results.jsonl",
        "episodes.csv",
        "episodes.parquet",
        "summary.json",
        "summary.txt",
        "charts.svg",
    ] {
        assert!(
            service.join(f).is_file(),
            "vb-submit results --out wrote no {f}"
        );
    }
    let (sh, srows) = csv_without_wall_time(&service.join("episodes.csv"));
    let (lh, lrows) = csv_without_wall_time(&local.join("episodes.csv"));
    assert_eq!(sh, lh, "the same columns");
    assert_eq!(srows.len(), 10);
    assert_eq!(srows, lrows, "the same episodes, value for value");
    assert_eq!(
        summary_without_wall_time(&service.join("summary.json")),
        summary_without_wall_time(&local.join("summary.json"))
    );
    // vb compare takes the service's directory beside the local one: the same results, no difference.
    let cmp = vb_run(&[
        "compare",
        service.to_str().unwrap(),
        local.to_str().unwrap(),
    ]);
    assert!(cmp.contains("10"), "{cmp}");
    assert!(cmp.contains("+0.0"), "no difference: {cmp}");
    // The streamed CSV carries episodes.csv's columns and rows.
    let csv = run_command(results(&[]));
    let streamed = dir.join("streamed.csv");
    std::fs::write(&streamed, csv)?;
    assert_eq!(csv_without_wall_time(&streamed), (sh, srows));
    // A directory that already holds an evaluation is refused (nothing overwritten).
    let again = results(&["--out", local.to_str().unwrap()]).output()?;
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("already holds an evaluation"));
    Ok(())
}
