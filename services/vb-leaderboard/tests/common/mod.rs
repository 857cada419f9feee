//! The committed task set served as the `vb` binary wires it: its catalog (`eval::catalog`) and its worlds drawn by
//! `tasks`.

use std::sync::Arc;
use vb_leaderboard::ServedTasks;

/// This build's simulator version, which ranked runs must carry.
pub const SIM_VERSION: &str = eval::SIM_VERSION;

pub fn committed() -> anyhow::Result<(tasks::TaskSet, ServedTasks)> {
    let set = tasks::TaskSet::committed()?;
    let drawn = set.clone();
    let served = ServedTasks {
        catalog: Arc::new(eval::catalog(&set)),
        draw: Arc::new(move |id| {
            drawn
                .world_picture(id, vb_leaderboard::pages::MAP_PPM)
                .map_err(|e| e.to_string())
        }),
    };
    Ok((set, served))
}
