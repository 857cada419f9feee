//! `vb bench service`: the service's overhead. Times a built-in planner's evaluation in-process (`vb eval`) and
//! through the whole service (`vb serve --evaluate ... --exit-when-done`: the gRPC submission API, the coordinator,
//! the SQLite store and its in-process workers) on the same machine, one after the other, and checks that both give
//! the same success rate.

use anyhow::{bail, Context};
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// Runs `vb ARGS` to completion; its wall time in seconds and its stdout.
fn timed_vb(args: &[&str]) -> anyhow::Result<(f64, String)> {
    let exe = std::env::current_exe().context("locating this vb binary")?;
    let t0 = Instant::now();
    let out = Command::new(&exe)
        .args(args)
        .output()
        .with_context(|| format!("running vb {}", args.join(" ")))?;
    let wall = t0.elapsed().as_secs_f64();
    if !out.status.success() {
        bail!(
            "vb {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok((wall, String::from_utf8_lossy(&out.stdout).into_owned()))
}

/// The success rate of the one submission in the store at `db`.
fn service_success(db: &str) -> anyhow::Result<(f64, usize)> {
    tokio::runtime::Runtime::new()?.block_on(async {
        let reader = vb_store::Reader::open(db).await?;
        let subs = reader.submissions().await?;
        let sub = subs.first().context("the service stored no submission")?;
        let eps = reader.episodes(&sub.id).await?;
        let s = vb_store::aggregate::summary_of(sub, &eps, None)?;
        Ok((s.overall.success_rate, s.overall.episodes))
    })
}

fn local_success(dir: &Path) -> anyhow::Result<(f64, usize)> {
    let p = dir.join("summary.json");
    let s: eval::summary::Summary = serde_json::from_str(
        &std::fs::read_to_string(&p).with_context(|| format!("reading {}", p.display()))?,
    )?;
    Ok((s.overall.success_rate, s.overall.episodes))
}

pub fn run(planner: &str, tasks: &str, slots: usize) -> anyhow::Result<()> {
    let tmp = std::env::temp_dir().join(format!("vb-bench-service-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(&tmp)?;
    let result = (|| {
        let out = tmp.join("eval");
        let threads = slots.to_string();
        let out_s = out.display().to_string();
        println!("in-process: vb eval --planner {planner} --tasks {tasks} --threads {threads}");
        let (local_wall, _) = timed_vb(&[
            "eval",
            "--planner",
            planner,
            "--tasks",
            tasks,
            "--threads",
            &threads,
            "--out",
            &out_s,
        ])?;
        let db = format!("sqlite://{}", tmp.join("vb.db").display());
        println!("service:    vb serve --evaluate {planner} --tasks {tasks} --slots {threads} --exit-when-done");
        let (service_wall, _) = timed_vb(&[
            "serve",
            "--db",
            &db,
            "--grpc",
            "127.0.0.1:0",
            "--http",
            "127.0.0.1:0",
            "--slots",
            &threads,
            "--evaluate",
            planner,
            "--tasks",
            tasks,
            "--exit-when-done",
        ])?;
        let (ls, ln) = local_success(&out)?;
        let (ss, sn) = service_success(&db)?;
        println!(
            "in-process {local_wall:.1} s ({ln} episodes, success {:.1}%); service {service_wall:.1} s ({sn} episodes, \
             success {:.1}%); overhead {:.2}x",
            100.0 * ls,
            100.0 * ss,
            service_wall / local_wall
        );
        if (ln, ls) != (sn, ss) {
            bail!("the service's results differ from the in-process evaluation's");
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&tmp);
    result
}
