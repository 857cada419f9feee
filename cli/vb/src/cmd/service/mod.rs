//! `vb serve`, `vb coordinator`, `vb worker`, `vb leaderboard`, `vb admin`: the evaluation service. One file per
//! command group: [`args`] (their arguments), [`common`] (runtime, stop signal, store, sockets, starting the
//! coordinator), [`serve`] (`vb serve`, `vb coordinator`), [`worker`], [`leaderboard`] and [`admin`].

mod admin;
mod args;
pub(crate) mod common;
mod leaderboard;
mod serve;
mod worker;

pub use admin::admin;
pub use args::{AdminCmd, CoordinatorArgs, LeaderboardArgs, ServeArgs, WorkerArgs};
pub use leaderboard::leaderboard;
pub use serve::{coordinator, serve};
pub use worker::worker;
