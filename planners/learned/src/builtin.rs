//! The built-in learned planners: the end-to-end policies `rl`, `mcl`, `acl`, and the hybrids `mppi6` and `wmvct`
//! (MPPI-6 over a learned kinodynamic model, whole or decomposed), `tal` (over the terrain-attentive model) and
//! `tnt` (over the terrain-attentive model with the traversability estimator's cost), with the weights committed
//! in `planners/learned/weights/`, compiled in, or any weights file a user trained (its `format` says which kind
//! of planner it makes; a traversability estimator's file runs over the compiled-in `tal` model).

use crate::kino::{tnt, Dynamics, KinoMppi, KinoMppiConfig, Rollout, TravNet};
use crate::net::{PolicyNet, WeightsError};
use crate::planner::LearnedPlanner;
use sim_core::planner::Planner;
use std::path::Path;

include!(concat!(env!("OUT_DIR"), "/builtin.rs"));

/// Names of the built-in learned planners.
pub const NAMES: [&str; 7] = ["rl", "mcl", "acl", "mppi6", "wmvct", "tal", "tnt"];

/// What a built-in learned planner runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// An end-to-end policy (`python -m vertibench.train NAME`).
    Policy,
    /// A kinodynamic model of `python -m vertibench.kino train --model MODEL`, rolled out by MPPI-6 so.
    Model(&'static str, Rollout),
}

/// The built-in learned planners: their weights file and what it holds (`wmvct` rolls out `mppi6`'s model,
/// decomposed; `tnt`'s file is the estimator, rolled out over `tal`'s model). Any other name given a model file rolls
/// it out whole.
const PLANNERS: [(&str, &str, Kind); 7] = [
    ("rl", "rl", Kind::Policy),
    ("mcl", "mcl", Kind::Policy),
    ("acl", "acl", Kind::Policy),
    ("mppi6", "mppi6", Kind::Model("kino", Rollout::Learned)),
    ("wmvct", "mppi6", Kind::Model("kino", Rollout::Decomposed)),
    ("tal", "tal", Kind::Model("tal", Rollout::Learned)),
    ("tnt", "tnt", Kind::Model("tnt", Rollout::Learned)),
];

/// A built-in planner's weights file and kind.
fn planner(name: &str) -> Option<(&'static str, Kind)> {
    PLANNERS
        .iter()
        .find(|(n, _, _)| *n == name)
        .map(|&(_, file, kind)| (file, kind))
}

/// Whose weights file a built-in planner runs.
fn weights_name(name: &str) -> &str {
    planner(name).map_or(name, |(file, _)| file)
}

/// How MPPI-6 rolls out a kinodynamic model for the planner `name`.
fn rollout_of(name: &str) -> Rollout {
    match planner(name) {
        Some((_, Kind::Model(_, rollout))) => rollout,
        _ => Rollout::Learned,
    }
}

/// How a built-in planner's weights are made.
fn how_to_train(name: &str) -> String {
    match planner(name) {
        Some((_, Kind::Model(model, _))) => format!(
            "generate datasets and train a model with `python -m vertibench.kino train --model {model} --data \
             DIR... --out DIR` (planners/learned/KINO.md) and run it with `--weights DIR/{model}.safetensors`"
        ),
        _ => format!(
            "train it with `python -m vertibench.train {name} --out DIR` and run it with `--weights \
             DIR/policy.safetensors`"
        ),
    }
}

/// Why a learned planner could not be made.
#[derive(Debug, thiserror::Error)]
pub enum LearnedError {
    #[error(
        "the built-in planner `{name}` has no weights in this build: {how}, or commit the file as \
         planners/learned/weights/{file}.safetensors and rebuild"
    )]
    NoWeights {
        name: String,
        file: String,
        how: String,
    },
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
    NAMES
        .into_iter()
        .filter(|n| {
            BUILTIN
                .iter()
                .any(|(w, bytes)| *w == weights_name(n) && bytes.is_some())
        })
        .collect()
}

/// What a learned planner runs: an end-to-end policy, a kinodynamic model that MPPI-6 rolls out, or such a model
/// with a traversability estimator whose grid adds to the rollouts' cost.
#[derive(Clone, Debug)]
pub enum LearnedNet {
    Policy(PolicyNet),
    Kino(Dynamics),
    Traversability(Dynamics, Box<TravNet>),
}

impl LearnedNet {
    /// A weights file's bytes: a `vertibench-kino-v1` or `vertibench-tal-v1` file is a kinodynamic model, a
    /// `vertibench-tnt-v1` file a traversability estimator (over the compiled-in `tal` model), any other must be a
    /// policy.
    pub fn from_bytes(bytes: &[u8]) -> Result<LearnedNet, WeightsError> {
        if Dynamics::is_model_format(bytes) {
            Dynamics::from_bytes(bytes).map(LearnedNet::Kino)
        } else if crate::nn::format(bytes).as_deref() == Some(tnt::TNT_LAYOUT) {
            let trav = TravNet::from_bytes(bytes)?;
            let tal = BUILTIN
                .iter()
                .find(|(n, _)| *n == "tal")
                .and_then(|(_, b)| *b)
                .ok_or_else(|| {
                    WeightsError::Format(
                        "a traversability estimator runs over the built-in `tal` model, which this build lacks"
                            .into(),
                    )
                })?;
            Ok(LearnedNet::Traversability(
                Dynamics::from_bytes(tal)?,
                Box::new(trav),
            ))
        } else {
            PolicyNet::from_bytes(bytes).map(LearnedNet::Policy)
        }
    }

    /// SHA-256 of the weights file (hex; for an estimator, its file's and then the model's, joined by `+`).
    pub fn sha256(&self) -> String {
        match self {
            LearnedNet::Policy(n) => n.sha256().to_string(),
            LearnedNet::Kino(n) => n.sha256().to_string(),
            LearnedNet::Traversability(d, t) => format!("{}+{}", t.sha256(), d.sha256()),
        }
    }

    /// A fresh planner for one episode, reported as `name`: a policy drives itself; a kinodynamic model is rolled
    /// out by MPPI-6, whole, or under the name `wmvct` decomposed as WM-VCT does (x, y and yaw from a bicycle).
    pub fn make(&self, name: &str) -> Box<dyn Planner> {
        match self {
            LearnedNet::Policy(n) => Box::new(LearnedPlanner::new(name, n.clone())),
            LearnedNet::Kino(n) => {
                let cfg = KinoMppiConfig {
                    rollout: rollout_of(name),
                    ..KinoMppiConfig::default()
                };
                Box::new(KinoMppi::new(name, n.clone(), cfg))
            }
            LearnedNet::Traversability(d, t) => Box::new(
                KinoMppi::new(name, d.clone(), KinoMppiConfig::default())
                    .with_traversability((**t).clone()),
            ),
        }
    }
}

/// The network of a built-in learned planner, or `None` if `name` is not one.
pub fn builtin(name: &str) -> Option<Result<LearnedNet, LearnedError>> {
    if !is_learned(name) {
        return None;
    }
    let file = weights_name(name);
    let (_, weights) = BUILTIN.iter().find(|(n, _)| *n == file)?;
    Some(match weights {
        None => Err(LearnedError::NoWeights {
            name: name.to_string(),
            file: file.to_string(),
            how: how_to_train(name),
        }),
        Some(bytes) => LearnedNet::from_bytes(bytes).map_err(|source| LearnedError::Weights {
            path: format!("planners/learned/weights/{file}.safetensors (compiled in)"),
            source,
        }),
    })
}

/// The network of a weights file (a policy or a kinodynamic model).
pub fn load(path: &Path) -> Result<LearnedNet, LearnedError> {
    read_weights(path, LearnedNet::from_bytes)
}

/// The policy of a weights file.
pub fn load_policy(path: &Path) -> Result<PolicyNet, LearnedError> {
    read_weights(path, PolicyNet::from_bytes)
}
/// A weights file read and parsed by `parse`, its errors naming the file.
pub(crate) fn read_weights<T>(
    path: &Path,
    parse: impl FnOnce(&[u8]) -> Result<T, WeightsError>,
) -> Result<T, LearnedError> {
    let shown = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| LearnedError::Io {
        path: shown.clone(),
        message: e.to_string(),
    })?;
    parse(&bytes).map_err(|source| LearnedError::Weights {
        path: shown,
        source,
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn every_name_has_its_weights_file_and_wmvct_runs_mppi6s_model_decomposed() {
        let listed: Vec<&str> = super::PLANNERS.iter().map(|(n, _, _)| *n).collect();
        assert_eq!(listed, super::NAMES);
        assert_eq!(super::weights_name("wmvct"), "mppi6");
        assert_eq!(super::rollout_of("wmvct"), super::Rollout::Decomposed);
        assert_eq!(super::rollout_of("mine"), super::Rollout::Learned);
    }
}
