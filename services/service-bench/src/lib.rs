//! Benchmark harnesses of the service tier, kept out of the product crates: [`seed`] fills a throw-away store with
//! finished submissions through the store's own API, [`http_load`] serves the leaderboard on loopback and measures
//! request latency under open-loop load (`vb bench leaderboard`).

pub mod http_load;
pub mod seed;
