//! `vb leaderboard-static DIR... --out FILE`: a standalone leaderboard page over evaluation directories, rendered by
//! the service's own board template.

use std::path::PathBuf;
use vb_leaderboard::pages::board::{standalone, Evaluation};
use vb_leaderboard::ranking::Reference;

#[derive(clap::Args)]
pub struct LeaderboardArgs {
    /// Evaluation directories (each with a summary.json written by `vb eval`).
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// The page to write (one self-contained HTML file).
    #[arg(long, default_value = "out/leaderboard.html")]
    pub out: PathBuf,
    /// Task-set directory whose full runs are ranked (default: the committed set); evaluations on another task set,
    /// simulator or rules are listed apart. Without a loadable set the most common set among the evaluations is
    /// ranked, full when as many tasks as its largest evaluation ran.
    #[arg(long, hide_default_value = true)]
    pub task_dir: Option<PathBuf>,
}

pub fn run(a: LeaderboardArgs) -> anyhow::Result<()> {
    let set = tasks::TaskSet::load(&a.task_dir.unwrap_or_else(tasks::embedded::default_dir)).ok();
    let mut evals = Vec::new();
    for d in &a.dirs {
        let p = d.join("summary.json");
        let text =
            std::fs::read_to_string(&p).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
        let summary: eval::summary::Summary =
            serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
        let name = d
            .canonicalize()
            .ok()
            .and_then(|c| c.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| d.display().to_string());
        evals.push(Evaluation { name, summary });
    }
    if let Some(parent) = a.out.parent() {
        std::fs::create_dir_all(parent)?;
    }
    let reference = set.map(|s| {
        let tasks = s.world_ids().len() as u32 * contracts::catalog::TASKS_PER_WORLD;
        Reference::current(s.version(), tasks, eval::SIM_VERSION)
    });
    std::fs::write(&a.out, standalone(&evals, eval::SIM_VERSION, reference))?;
    println!("leaderboard: {}", a.out.canonicalize()?.display());
    Ok(())
}
