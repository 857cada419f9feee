//! `vb leaderboard DIR... --out FILE`: a static leaderboard page over evaluation directories.

use std::path::PathBuf;

#[derive(clap::Args)]
pub struct LeaderboardArgs {
    /// Evaluation directories (each with a summary.json written by `vb eval`).
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    #[arg(long, default_value = "out/leaderboard.html")]
    pub out: PathBuf,
}

pub fn run(a: LeaderboardArgs) -> anyhow::Result<()> {
    let mut summaries = Vec::new();
    for d in &a.dirs {
        let p = d.join("summary.json");
        let text =
            std::fs::read_to_string(&p).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?;
        summaries.push(
            serde_json::from_str(&text).map_err(|e| anyhow::anyhow!("{}: {e}", p.display()))?,
        );
    }
    if let Some(parent) = a.out.parent() {
        std::fs::create_dir_all(parent)?;
    }
    std::fs::write(&a.out, eval::report::leaderboard_html(&summaries))?;
    println!("leaderboard: {}", a.out.canonicalize()?.display());
    Ok(())
}
