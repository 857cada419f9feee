//! The built-in planners by name, the one lookup for `vb eval`, the workers, the service's catalogue and Python: the
//! classical baselines (`planners/baselines`) and the learned planners (`planners/learned`: those whose weights
//! this build carries, or any weights file given with `--weights`). A worker links this, not the evaluator.

use learned::LearnedNet;
use sim_core::planner::Planner;
use std::path::Path;

/// Why a name (and weights file) makes no planner; the message says what would.
#[derive(Debug, thiserror::Error)]
#[error("invalid planner: {message}")]
pub struct RegistryError {
    pub message: String,
}

/// A built-in planner, resolved once and made afresh for every episode by [`Builtin::make`].
#[derive(Clone, Debug)]
pub struct Builtin {
    name: String,
    learned: Option<LearnedNet>,
}

impl Builtin {
    /// The planner `name`: a classical baseline, or a learned one with its compiled-in weights or, given
    /// `weights`, that file's (then `name` is only the label; a learned name without weights in this build and
    /// without `weights` is an error that says how to train it).
    pub fn resolve(name: &str, weights: Option<&Path>) -> Result<Builtin, RegistryError> {
        let param = |message: String| RegistryError { message };
        if let Some(path) = weights {
            if baselines::NAMES.contains(&name) {
                return Err(param(format!(
                    "`{name}` is a classical baseline: weights are for learned planners (choose a name such as \
                     rl, mcl, acl or your own)"
                )));
            }
            let net = learned::builtin::load(path).map_err(|e| param(e.to_string()))?;
            return Ok(Builtin {
                name: name.to_string(),
                learned: Some(net),
            });
        }
        if baselines::NAMES.contains(&name) {
            return Ok(Builtin {
                name: name.to_string(),
                learned: None,
            });
        }
        match learned::builtin::builtin(name) {
            Some(Ok(net)) => Ok(Builtin {
                name: name.to_string(),
                learned: Some(net),
            }),
            Some(Err(e)) => Err(param(e.to_string())),
            None => Err(param(format!(
                "unknown planner `{name}` (built-in: {})",
                names().join(", ")
            ))),
        }
    }

    /// Its name (the rows' `planner` label).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// A fresh planner for one episode.
    pub fn make(&self) -> Box<dyn Planner> {
        match &self.learned {
            Some(net) => net.make(&self.name),
            None => baselines::by_name(&self.name).expect("resolved as a baseline"),
        }
    }

    /// A learned planner's version, `weights sha256:HEX` (a resumed evaluation must run the same weights); None
    /// for a classical baseline.
    pub fn weights_version(&self) -> Option<String> {
        self.learned
            .as_ref()
            .map(|net| format!("weights sha256:{}", net.sha256()))
    }
}

/// The built-in planners this build can run: the baselines and the learned ones with compiled-in weights.
pub fn names() -> Vec<&'static str> {
    let mut all = baselines::NAMES.to_vec();
    all.extend(learned::builtin::available());
    all
}
