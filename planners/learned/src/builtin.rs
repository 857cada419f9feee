//! The built-in learned planners (`rl`, `mcl`, `acl`): the weights committed in `planners/learned/weights/`,
//! compiled in, or any weights file a user trained.

use crate::net::{PolicyNet, WeightsError};
use crate::planner::LearnedPlanner;
use std::path::Path;

include!(concat!(env!("OUT_DIR"), "/builtin.rs"));

/// Names of the built-in learned planners.
pub const NAMES: [&str; 3] = ["rl", "mcl", "acl"];

/// Why a learned planner could not be made.
#[derive(Debug, thiserror::Error)]
pub enum LearnedError {
    #[error(
        "the built-in planner `{0}` has no weights in this build: train it with `python -m vertibench.train {0} \
         --out DIR` and run it with `--weights DIR/policy.safetensors`, or commit the file as \
         planners/learned/weights/{0}.safetensors and rebuild"
    )]
    NoWeights(String),
    #[error("weights file {path}: {source}")]
    Weights {
        path: String,
        #[source]
        source: WeightsError,
    },
    #[error("weights file {path}: {message}")]
    Io { path: String, message: String },
}

/// Whether `name` is a built-in learned planner (with or without weights in this build).
pub fn is_learned(name: &str) -> bool {
    NAMES.contains(&name)
}

/// The built-in learned planners whose weights this build carries.
pub fn available() -> Vec<&'static str> {
    BUILTIN
        .iter()
        .filter(|(_, w)| w.is_some())
        .map(|(n, _)| *n)
        .collect()
}

/// The network of a built-in learned planner, or `None` if `name` is not one.
pub fn builtin_net(name: &str) -> Option<Result<PolicyNet, LearnedError>> {
    let (_, weights) = BUILTIN.iter().find(|(n, _)| *n == name)?;
    Some(match weights {
        None => Err(LearnedError::NoWeights(name.to_string())),
        Some(bytes) => PolicyNet::from_bytes(bytes).map_err(|source| LearnedError::Weights {
            path: format!("planners/learned/weights/{name}.safetensors (compiled in)"),
            source,
        }),
    })
}

/// A built-in learned planner, or `None` if `name` is not one.
pub fn by_name(name: &str) -> Option<Result<LearnedPlanner, LearnedError>> {
    builtin_net(name).map(|net| net.map(|n| LearnedPlanner::new(name, n)))
}

/// The network of a weights file.
pub fn load(path: &Path) -> Result<PolicyNet, LearnedError> {
    let shown = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| LearnedError::Io {
        path: shown.clone(),
        message: e.to_string(),
    })?;
    PolicyNet::from_bytes(&bytes).map_err(|source| LearnedError::Weights {
        path: shown,
        source,
    })
}
