//! `vb bench leaderboard`: the leaderboard under HTTP load over a seeded (or an existing) store.

use std::path::PathBuf;

/// What the command was asked for.
#[derive(clap::Args)]
pub struct Args {
    /// Finished submissions to seed.
    #[arg(long, default_value_t = 100)]
    pub submissions: usize,
    /// Episodes per submission.
    #[arg(long, default_value_t = 1000)]
    pub episodes: usize,
    /// Rows of each episode's trajectory (a 60 s episode logged at 10 Hz has 600).
    #[arg(long, default_value_t = 600)]
    pub trajectory_rows: usize,
    /// Requests per second, per path.
    #[arg(long, default_value_t = 500.0)]
    pub rate: f64,
    /// Seconds of load per path.
    #[arg(long, default_value_t = 10.0)]
    pub seconds: f64,
    /// Store to seed: a throw-away database (default: a new SQLite file in a temporary directory, removed after).
    /// One that already holds at least `--submissions` submissions is measured as it is.
    #[arg(long)]
    pub db: Option<String>,
    #[arg(long)]
    pub task_dir: Option<PathBuf>,
}

pub fn run(a: Args) -> anyhow::Result<()> {
    let Args {
        submissions,
        episodes,
        trajectory_rows,
        rate,
        seconds,
        db,
        task_dir,
    } = a;
    let set = tasks::TaskSet::load(&task_dir.unwrap_or_else(tasks::embedded::default_dir))?;
    let tmp = std::env::temp_dir().join(format!("vb-bench-leaderboard-{}", std::process::id()));
    let url = match db {
        Some(u) => u,
        None => {
            std::fs::create_dir_all(&tmp)?;
            format!("sqlite://{}", tmp.join("vb.db").display())
        }
    };
    let rt = tokio::runtime::Runtime::new()?;
    let result = rt.block_on(async {
        let store = vb_store::Store::open(&url).await?;
        let existing: Vec<String> = store.reader().submissions().await?.into_iter().map(|s| s.id).collect();
        let ids = if existing.len() >= submissions.max(1) {
            println!("measuring the {} submissions already in {url}", existing.len());
            existing
        } else {
            let t0 = std::time::Instant::now();
            let ids = service_bench::seed::seed(&store, &eval::catalog(&set), submissions, episodes, trajectory_rows).await?;
            println!(
                "seeded {submissions} submissions x {episodes} episodes ({trajectory_rows}-row trajectories) in {:.0} s on {url}",
                t0.elapsed().as_secs_f64()
            );
            ids
        };
        let served = super::service::common::served_tasks(set);
        let lb = vb_leaderboard::Leaderboard::new(store.reader(), sim_core::SIM_VERSION, Some(served));
        let addr = service_bench::http_load::serve_loopback(lb).await?;
        let id = &ids[ids.len() / 2];
        println!("path                                   rate/s  requests  failed    p50 ms    p99 ms    max ms   bytes");
        for path in [
            "/".to_string(),
            "/api/submissions".to_string(),
            format!("/api/submissions/{id}"),
            format!("/submissions/{id}"),
        ] {
            let r = service_bench::http_load::load(addr, &path, rate, seconds).await;
            println!(
                "{:<38} {:>6.0} {:>9} {:>7} {:>9.2} {:>9.2} {:>9.2} {:>7}",
                r.path, r.rate, r.requests, r.failed, r.p50_ms, r.p99_ms, r.max_ms, r.bytes
            );
        }
        anyhow::Ok(())
    });
    if tmp.exists() {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}
