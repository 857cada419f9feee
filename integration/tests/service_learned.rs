//! The learned built-in planners through the service, end to end over real gRPC: `vb-submit builtin rl` and
//! `builtin mppi6` are accepted by the coordinator's catalogue, run by a `vb worker` process from its compiled-in
//! weights, and give exactly the episodes `vb eval` gives for the same tasks (same outcome, time and path length).

use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;

const TASKS: [&str; 2] = ["w001-t0", "w002-t3"];

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn learned_builtins_run_on_workers_as_vb_eval_runs_them() -> anyhow::Result<()> {
    let names: Vec<&str> = ["rl", "mppi6"]
        .into_iter()
        .filter(|n| learned::builtin::available().contains(n))
        .collect();
    if names.is_empty() {
        eprintln!("SKIPPED: this build carries no learned weights");
        return Ok(());
    }
    let dir = temp_dir("service-learned");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker(&dir, "worker", &db, port, 2);
    let mut c = client(port, &token).await;
    for name in names {
        let req = pb::SubmitRequest {
            name: format!("learned-{name}"),
            planner: Some(pb::PlannerRef {
                kind: Some(pb::planner_ref::Kind::Builtin(name.into())),
            }),
            task_ids: TASKS.iter().map(|t| t.to_string()).collect(),
            ..Default::default()
        };
        let id = vb_submit::submit(&mut c, req).await?.submission_id;
        wait_for(port, &token, &id, Duration::from_secs(600), |s| {
            s.finished == TASKS.len() as u32
        })
        .await;
        let served = vb_submit::results(&mut c, &id).await?;
        let out = dir.join(format!("eval-{name}"));
        vb_run(&[
            "eval",
            "--planner",
            name,
            "--tasks",
            &TASKS.join(","),
            "--out",
            &out.display().to_string(),
        ]);
        let local: Vec<serde_json::Value> = std::fs::read_to_string(out.join("results.jsonl"))?
            .lines()
            .map(serde_json::from_str)
            .collect::<Result<_, _>>()?;
        assert_eq!(served.episodes.len(), TASKS.len());
        for e in &served.episodes {
            let row = local
                .iter()
                .find(|r| r["task_id"] == e.task_id.as_str())
                .expect("vb eval ran the task");
            let m = e.metrics.as_ref().expect("a finished episode has metrics");
            let outcome = format!("{:?}", e.outcome()).to_lowercase();
            assert_eq!(
                outcome.replace('_', ""),
                row["outcome"].as_str().unwrap().replace('_', ""),
                "{name} {}",
                e.task_id
            );
            assert_eq!(
                m.time,
                row["metrics"]["time"].as_f64(),
                "{name} {}",
                e.task_id
            );
            assert_eq!(
                m.path_length,
                row["metrics"]["path_length"].as_f64(),
                "{name} {}",
                e.task_id
            );
        }
    }
    Ok(())
}
