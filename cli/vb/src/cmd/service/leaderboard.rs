//! `vb leaderboard`: the HTTP leaderboard over the coordinator's store (read only).

use super::args::LeaderboardArgs;
use super::common::{bind, runtime, served_tasks, StopSignal};
use anyhow::Context;
use vb_leaderboard::Leaderboard;

pub fn leaderboard(a: LeaderboardArgs) -> anyhow::Result<()> {
    let limits = a.net.limits()?;
    runtime()?.block_on(async move {
        let mut signal = StopSignal::new()?;
        let reader = vb_store::Reader::open(&a.db)
            .await
            .with_context(|| format!("opening the store at {}", a.db))?;
        let served = tasks::TaskSet::load(&a.task_dir).ok().map(served_tasks);
        let listener = bind(a.listen, "leaderboard").await?;
        tracing::info!(url = %format!("http://{}/", listener.local_addr()?), "leaderboard listening");
        tokio::select! {
            r = vb_leaderboard::serve_with(Leaderboard::new(reader, sim_core::SIM_VERSION, served), listener, &limits) => r?,
            _ = signal.recv() => {}
        }
        Ok(())
    })
}
