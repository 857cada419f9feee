//! Learned kinodynamic models (layout `vertibench-kino-v1`, `KINO.md`): what they see ([`features`]) and their
//! inference ([`net::KinoNet`]), for the hybrid planners that roll them out.

pub mod features;
pub mod mppi;
pub mod net;

pub use mppi::{KinoMppi, KinoMppiConfig, Rollout};
pub use net::KinoNet;

/// The model of a weights file.
pub fn load(path: &std::path::Path) -> Result<KinoNet, crate::LearnedError> {
    crate::builtin::read_weights(path, KinoNet::from_bytes)
}
