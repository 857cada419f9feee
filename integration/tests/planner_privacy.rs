//! Issue 58, points 2 and 4, over real processes: what a failing planner prints, its program and its URL reach only
//! its owner; under the default isolation (no `--planner-user`) a planner cannot read the worker's token file; a
//! planner whose command lives below `/tmp` (a virtual environment, a binary named inside `sh -c`) sees the files
//! it needs.

use integration::*;
use std::time::Duration;
use vb_proto::v1 as pb;
use vb_proto::ProtoEnum;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_that_prints_the_worker_s_token_file_shows_the_public_nothing(
) -> anyhow::Result<()> {
    if !namespaces_available(None).await {
        return Ok(());
    }
    let dir = temp_dir("token-file");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let worker_token = create_token_with_role(&db, "worker", "worker");
    let token_file = dir.join("worker.token");
    std::fs::write(&token_file, &worker_token)?;
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let token_arg = token_file.display().to_string();
    let url = format!("http://127.0.0.1:{port}");
    let _worker = Proc::start(
        "worker",
        &dir,
        &vb(),
        &[
            "worker",
            "--coordinator",
            &url,
            "--slots",
            "1",
            "--token-file",
            &token_arg,
        ],
    );
    let http = free_port();
    let _lb = Proc::start(
        "leaderboard",
        &dir,
        &vb(),
        &[
            "leaderboard",
            "--db",
            &db,
            "--listen",
            &format!("127.0.0.1:{http}"),
        ],
    );
    // It prints the token file (and a marker), then exits without serving.
    let script = format!(
        "echo MARKER-out-{pid}; cat {tf}; echo; echo \"READ: $(wc -c < {tf})\"; exit 3",
        pid = std::process::id(),
        tf = token_file.display()
    );
    let mut c = client(port, &token).await;
    let argv = vec!["sh".to_string(), "-c".to_string(), script];
    let sub = vb_submit::submit(&mut c, exec_argv_submission("leaky", &["w001-t0"], argv)).await?;
    let id = sub.submission_id.clone();
    wait_for(port, &token, &id, Duration::from_secs(120), |s| {
        s.state() == pb::SubmissionState::Done
    })
    .await;
    // The owner sees what happened: the planner's output (with an empty token file) and the worker's account.
    let log = vb_submit::episode_log(&mut c, &id, contracts::TaskId::new(1, 0)).await?;
    assert!(
        log.contains("READ: 0"),
        "the planner read the token file: {log}"
    );
    assert!(!log.contains(&worker_token), "{log}");
    let r = vb_submit::results(&mut c, &id).await?;
    let detail = &r.episodes[0].detail;
    assert!(detail.contains("exited"), "the owner's detail: {detail}");
    // The public sees neither the output nor the program, on every page and API answer about the episode.
    wait_port(http, Duration::from_secs(60));
    let marker = format!("MARKER-out-{}", std::process::id());
    for path in [
        format!("/submissions/{id}"),
        format!("/submissions/{id}/episodes/w001-t0"),
        format!("/api/submissions/{id}"),
        format!("/api/submissions/{id}/episodes"),
        format!("/api/submissions/{id}/episodes/w001-t0"),
    ] {
        let body = http_text(http, &path);
        for secret in [marker.as_str(), worker_token.as_str(), "exited", "wc -c"] {
            assert!(!body.contains(secret), "{path} shows `{secret}`: {body}");
        }
    }
    let page = http_text(http, &format!("/submissions/{id}/episodes/w001-t0"));
    assert!(
        page.contains(
            &contracts::EndReason::PlannerCrash
                .public_sentence()
                .replace('\'', "&#39;")
        ),
        "the public reason: {page}"
    );
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_planner_below_tmp_sees_its_environment_and_binaries_named_inside_sh_c(
) -> anyhow::Result<()> {
    if !namespaces_available(None).await {
        return Ok(());
    }
    let dir = temp_dir("tmp-planner");
    let db = format!("sqlite://{}", dir.join("vb.db").display());
    let token = create_token(&db);
    let port = free_port();
    let _coordinator = start_coordinator(&dir, "coordinator", &db, port);
    let _worker = start_worker(&dir, "worker", &db, port, 1);
    // A fake environment below /tmp: bin/planner (a copy of the example planner) beside a config file and lib/ that
    // the start script reads, as a virtual environment's interpreter reads pyvenv.cfg and lib/.
    let env = std::path::PathBuf::from(format!("/tmp/vb-env-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&env);
    std::fs::create_dir_all(env.join("bin"))?;
    std::fs::create_dir_all(env.join("lib"))?;
    std::fs::write(env.join("pyvenv.cfg"), "home = /usr/bin\n")?;
    std::fs::write(env.join("lib").join("module.txt"), "loaded\n")?;
    std::fs::copy(example_planner(), env.join("bin").join("planner"))?;
    let script = format!(
        "cat {e}/pyvenv.cfg {e}/lib/module.txt && exec {e}/bin/planner",
        e = env.display()
    );
    let mut c = client(port, &token).await;
    let argv = vec!["sh".to_string(), "-c".to_string(), script];
    let sub = vb_submit::submit(
        &mut c,
        exec_argv_submission("below-tmp", &["w001-t0"], argv),
    )
    .await?;
    let s = wait_for(
        port,
        &token,
        &sub.submission_id,
        Duration::from_secs(180),
        |s| s.state() == pb::SubmissionState::Done,
    )
    .await;
    let r = vb_submit::results(&mut c, &sub.submission_id).await?;
    let e = &r.episodes[0];
    let log =
        vb_submit::episode_log(&mut c, &sub.submission_id, contracts::TaskId::new(1, 0)).await?;
    let _ = std::fs::remove_dir_all(&env);
    assert!(
        log.contains("loaded"),
        "the planner did not see lib/: {log}"
    );
    let reason = e
        .reason
        .and_then(|r| contracts::EndReason::from_wire(r).ok());
    assert!(
        !matches!(
            reason,
            Some(contracts::EndReason::PlannerCrash | contracts::EndReason::PlannerUnreachable)
        ),
        "the planner did not start: {s:?} {} {log}",
        e.detail
    );
    Ok(())
}
