//! One module per subcommand group. Each parses its arguments and calls a library.

pub mod bench;
pub mod bench_leaderboard;
pub mod bench_move_off;
pub mod bench_service;
pub mod compare;
pub mod dataset;
pub mod eval;
pub mod leaderboard;
pub mod net_args;
pub mod service;
pub mod sim;
pub mod sim_characterize;
pub mod sim_drive;
pub mod tasks;
pub mod terrain;
