//! `vb eval`: evaluate a planner on the task set, locally and in parallel.

use sim_core::episode::EpisodeConfig;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct EvalArgs {
    /// Built-in planner: pid, eh, mppi (bicycle model), mppi-release (the original release's MPPI as published),
    /// mppi6-oracle (MPPI-6 over our own simulator), or a learned one: rl, mcl, acl (PPO policies on training
    /// worlds), mppi6 (MPPI-6 over a learned kinodynamic model), wmvct (the same, x, y and yaw from a bicycle), tal
    /// (MPPI-6 over the terrain-attentive model), tnt (tal with the traversability estimator's cost); their weights
    /// are compiled in once committed.
    #[arg(long, default_value = "pid")]
    planner: String,
    /// A learned planner's weights file (`policy.safetensors` of `python -m vertibench.train`, or a kinodynamic model
    /// or a traversability estimator of `python -m vertibench.kino train`), run under the name `--planner`.
    #[arg(long)]
    weights: Option<PathBuf>,
    /// `all`, or a comma-separated union of world ids (17), task ids (w017-t3) and named splits: low, medium,
    /// high (elevation), rigid, deformable, mixed (semantics), sparse, medium-density, dense (obstacles).
    #[arg(long, default_value = "all")]
    tasks: String,
    #[arg(long, default_value = "hmmwv")]
    vehicle: String,
    /// World scale (default: the vehicle's own scale).
    #[arg(long)]
    scale: Option<f64>,
    /// Task-set directory (default: the committed set).
    #[arg(long)]
    task_dir: Option<PathBuf>,
    /// Output directory (results.jsonl, episodes.csv, episodes.parquet, summary.json, summary.txt, charts.svg);
    /// running again resumes an interrupted evaluation.
    #[arg(long, default_value = "out/eval")]
    out: PathBuf,
    /// Use the original release's rules: 8 m goal radius, speed-based stuck (< 2 m/s for 10 s) and its post-hoc
    /// rollover classification (a failed trial whose |roll| or |pitch| ever exceeded 30 degrees).
    #[arg(long)]
    release_rules: bool,
    /// What the planner perceives: ideal (ground truth, the default), nominal, degraded, or a profile's TOML file
    /// (docs: perception/profiles/). Results carry the profile; a directory of another profile is not resumed.
    #[arg(long, default_value = "ideal")]
    perception: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
}

pub fn run(a: EvalArgs) -> anyhow::Result<()> {
    if let Some(t) = a.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(t.max(1))
            .build_global()?;
    }
    let episode = if a.release_rules {
        EpisodeConfig::release()
    } else {
        EpisodeConfig::default()
    };
    let builtin = eval::Builtin::resolve(&a.planner, a.weights.as_deref())?;
    let perception = eval::perception_profile(&a.perception)?;
    let cfg = eval::EvalConfig {
        identity: Some(eval::PlannerIdentity::of_builtin(&builtin)),
        planner: a.planner.into(),
        task_dir: a
            .task_dir
            .clone()
            .unwrap_or_else(tasks::embedded::default_dir),
        tasks: a.tasks,
        vehicle: a.vehicle.into(),
        scale: a.scale,
        out: a.out.clone(),
        out_param: "--out".into(),
        episode,
        perception,
    };
    let start = std::time::Instant::now();
    let progress = |done: usize, total: usize, secs: f64| {
        let width = 40;
        if !(done.is_multiple_of(10) || done == total) {
            return;
        }
        let filled = width * done / total.max(1);
        let eta = if done > 0 {
            secs / done as f64 * (total - done) as f64
        } else {
            0.0
        };
        eprint!(
            "\r[{}{}] {done}/{total} episodes, {secs:.0} s elapsed, ETA {eta:.0} s ",
            "#".repeat(filled),
            ".".repeat(width - filled)
        );
        let _ = std::io::stderr().flush();
    };
    let rows = eval::run_builtin(&cfg, &builtin, &progress)?;
    eprintln!();
    let summary = eval::summary::summarise(&rows);
    eval::report::write(&a.out, &rows, &summary)?;
    print!("{}", eval::report::summary_text(&summary));
    println!(
        "{} episodes in {:.1} s wall time; results in {}",
        rows.len(),
        start.elapsed().as_secs_f64(),
        a.out.display()
    );
    // Refresh the leaderboard over every evaluation next to this one.
    let parent = a
        .out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(parent)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("summary.json").is_file())
        .collect();
    dirs.sort();
    let page = parent.join("leaderboard.html");
    super::leaderboard::run(super::leaderboard::LeaderboardArgs {
        dirs,
        out: page,
        task_dir: a.task_dir.clone(),
    })
}
