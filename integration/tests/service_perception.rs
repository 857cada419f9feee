//! Perception profiles through the service, end to end over real gRPC and separate processes (issue 61): one request
//! under `ideal` and `nominal` becomes a family of two submissions; the worker runs the nominal one under the same
//! noise `vb eval --perception nominal` applies (the episodes are identical); a remote planner under a profile that
//! builds the map online receives the believed map and its updates; the leaderboard ranks only the ideal run and
//! shows the family's robustness table with the paired drop; bad profiles are refused with clear errors.

use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;

const TASKS: [&str; 4] = ["w001-t0", "w001-t1", "w002-t3", "w003-t2"];

fn builtin(name: &str, perception: &[&str]) -> pb::SubmitRequest {
    pb::SubmitRequest {
        name: format!("{name}-robust"),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Builtin(name.into())),
        }),
        task_ids: TASKS.iter().map(|t| t.to_string()).collect(),
        perception: perception.iter().map(|p| p.to_string()).collect(),
        ..Default::default()
    }
}

/// `vb eval --perception nominal`'s rows of the same tasks, by task id.
fn local_rows(dir: &std::path::Path, planner: &str, profile: &str) -> Vec<serde_json::Value> {
    let out = dir.join(format!("eval-{planner}-{profile}"));
    vb_run(&[
        "eval",
        "--planner",
        planner,
        "--tasks",
        &TASKS.join(","),
        "--perception",
        profile,
        "--out",
        &out.display().to_string(),
    ]);
    std::fs::read_to_string(out.join("results.jsonl"))
        .expect("results.jsonl")
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON row"))
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_family_of_profiles_runs_as_vb_eval_runs_it_and_the_board_shows_its_drop(
) -> anyhow::Result<()> {
    let dir = temp_dir("service-perception");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let port = free_port();
    let token = create_token(&db);
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker(&dir, "worker", &db, port, 2);
    let mut c = client(port, &token).await;

    // Bad profiles and a planner that reads ground-truth maps under a profile that degrades them are refused.
    for (req, expect) in [
        (
            builtin("pid", &["foggy"]),
            "unknown perception profile `foggy`",
        ),
        (builtin("pid", &["nominal", "nominal"]), "named twice"),
        (
            builtin("mppi6-oracle", &["ideal", "nominal"]),
            "reads the world's ground-truth maps",
        ),
    ] {
        let e = vb_submit::submit(&mut c, req)
            .await
            .unwrap_err()
            .to_string();
        assert!(e.contains(expect), "{e}");
    }

    let r = vb_submit::submit(&mut c, builtin("pid", &["ideal", "nominal"])).await?;
    assert_eq!(r.submission_ids.len(), 2);
    assert_eq!(r.submission_id, r.submission_ids[0]);
    let (ideal, nominal) = (&r.submission_ids[0], &r.submission_ids[1]);
    for id in &r.submission_ids {
        let s = wait_for(port, &token, id, Duration::from_secs(600), |s| {
            s.finished == TASKS.len() as u32
        })
        .await;
        assert_eq!(
            &s.family, ideal,
            "one family, named by its first submission"
        );
    }
    let s = vb_submit::status(&mut c, nominal).await?;
    assert!(s.perception.starts_with("nominal@"), "{}", s.perception);
    assert_eq!(vb_submit::status(&mut c, ideal).await?.perception, "ideal");

    // The worker applied the same noise as a local evaluation: identical episodes.
    let served = vb_submit::results(&mut c, nominal).await?;
    let json: serde_json::Value = serde_json::from_str(&vb_submit::results::json(&served)?)?;
    assert_eq!(json["perception"], s.perception.as_str());
    let local = local_rows(&dir, "pid", "nominal");
    for e in &served.episodes {
        let row = local
            .iter()
            .find(|r| r["task_id"] == e.task_id.as_str())
            .expect("vb eval ran the task");
        assert_eq!(row["perception"], s.perception.as_str());
        let m = e.metrics.as_ref().expect("metrics");
        assert_eq!(m.time, row["metrics"]["time"].as_f64(), "{}", e.task_id);
        assert_eq!(
            m.path_length,
            row["metrics"]["path_length"].as_f64(),
            "{}",
            e.task_id
        );
    }

    // A remote planner under nominal is given the belief and its updates (the example planner reports what it
    // knows of the map every 50 control steps, in its log): the map grows as the vehicle drives.
    let mut argv = vec![example_planner().display().to_string()];
    argv.extend(["--delay-ms".to_string(), "0".to_string()]);
    let remote = pb::SubmitRequest {
        name: "remote-nominal".into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner { argv })),
        }),
        task_ids: vec![TASKS[0].into()],
        step_deadline_s: 5.0,
        perception: vec!["nominal".into()],
        ..Default::default()
    };
    let rid = vb_submit::submit(&mut c, remote).await?.submission_id;
    wait_for(port, &token, &rid, Duration::from_secs(300), |s| {
        s.finished == 1
    })
    .await;
    let log = vb_submit::episode_log(&mut c, &rid, TASKS[0].parse()?).await?;
    let reports: Vec<Vec<usize>> = log
        .lines()
        .filter(|l| l.contains("believed map:"))
        .map(|l| {
            l.split_whitespace()
                .filter_map(|w| w.parse().ok())
                .collect()
        })
        .collect();
    assert!(reports.len() >= 2, "the planner's log:\n{log}");
    let (first, last) = (&reports[0], &reports[reports.len() - 1]);
    // known, cells, updates
    assert!(
        first[0] > 0 && last[0] > first[0] && last[0] < last[1],
        "{log}"
    );
    assert!(last[2] > first[2], "{log}");

    // The leaderboard: the nominal run is listed apart, the family's table shows the paired drop.
    let (_lb, lport) = start_leaderboard(&dir, &db);
    let board = http_text(lport, "/");
    assert!(board.contains("id=\"robustness\""), "{board}");
    assert!(
        board.contains(&format!("perception {}", s.perception)),
        "{board}"
    );
    let page = http_text(lport, &format!("/submissions/{ideal}"));
    assert!(page.contains("Robustness to perception"), "{page}");
    let (code, body) = http_get(lport, &format!("/api/submissions/{nominal}/robustness"));
    assert_eq!(code, 200);
    let table: serde_json::Value = serde_json::from_slice(&body)?;
    let profiles = table["profiles"].as_array().expect("profiles");
    assert_eq!(profiles.len(), 2);
    assert!(profiles[0]["drop_from_ideal"].is_null());
    let drop = &profiles[1]["drop_from_ideal"];
    assert_eq!(drop["paired_tasks"], TASKS.len());
    let (ok_ideal, ok_nominal) = (
        profiles[0]["success_rate"].as_f64().unwrap(),
        profiles[1]["success_rate"].as_f64().unwrap(),
    );
    assert!((drop["difference"].as_f64().unwrap() - (ok_nominal - ok_ideal)).abs() < 1e-12);
    let alone: serde_json::Value = serde_json::from_str(&http_text(
        lport,
        &format!("/api/submissions/{rid}/robustness"),
    ))?;
    assert_eq!(
        alone["profiles"].as_array().map(Vec::len),
        Some(1),
        "a family of one"
    );
    let table = board.split("id=\"robustness\"").nth(1).unwrap_or_default();
    assert!(
        table.contains("pid-robust") && !table.contains("remote-nominal"),
        "the board's table lists families of several only: {table}"
    );
    Ok(())
}
