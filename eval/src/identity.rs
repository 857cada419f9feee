//! Which planner an evaluation runs, kept in `planner.json` beside `results.jsonl`: a resumed evaluation must run
//! the planner that wrote the results it keeps. The rows themselves carry only the planner's label; two Python
//! planners with the same `name` but another class, version or parameters would otherwise mix.
//!
//! The file is optional: an output directory written before it existed resumes as before (its rows are checked) and
//! gets the file on its next run.

use crate::{io_err, EvalError};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The file beside `results.jsonl` that holds the evaluated planner's [`PlannerIdentity`].
pub const IDENTITY_FILE: &str = "planner.json";

/// Where a planner comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlannerSource {
    /// A built-in planner (`planners/baselines`), known by its name.
    Builtin,
    /// A Python planner run in-process (`vertibench.evaluate`).
    Python,
}

/// A planner's identity: two evaluations may share an output directory only when these are equal.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlannerIdentity {
    pub kind: PlannerSource,
    /// The built-in's name, or the Python planner's `name` (the rows' `planner` label).
    pub name: String,
    /// A Python planner's class, `module.qualname`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub class: Option<String>,
    /// A Python planner's explicit `version`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub version: Option<String>,
    /// SHA-256 (hex) of a Python planner's parameters, when it has no `version`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params_sha256: Option<String>,
    /// The parameters themselves, when small: only shown (which of them differ); the hash is what counts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub params: Option<serde_json::Map<String, serde_json::Value>>,
}

impl PlannerIdentity {
    /// The built-in planner `name`.
    pub fn builtin(name: &str) -> Self {
        PlannerIdentity {
            kind: PlannerSource::Builtin,
            name: name.to_string(),
            class: None,
            version: None,
            params_sha256: None,
            params: None,
        }
    }

    /// A resolved built-in: its name and, for a learned planner, its weights' version.
    pub fn of_builtin(b: &registry::Builtin) -> Self {
        PlannerIdentity {
            version: b.weights_version(),
            ..PlannerIdentity::builtin(b.name())
        }
    }

    /// Whether `other` is the same planner (the parameters themselves are not compared, their hash is).
    pub fn same(&self, other: &PlannerIdentity) -> bool {
        (
            &self.kind,
            &self.name,
            &self.class,
            &self.version,
            &self.params_sha256,
        ) == (
            &other.kind,
            &other.name,
            &other.class,
            &other.version,
            &other.params_sha256,
        )
    }

    /// Why `other` is another planner than `self`, for messages: `self`, `other` and the parameters that differ,
    /// where both name them.
    pub fn difference(&self, other: &PlannerIdentity) -> String {
        let mut s = format!("{}, not {}", self.describe(), other.describe());
        if let (Some(a), Some(b)) = (&self.params, &other.params) {
            let changed: Vec<String> = a
                .keys()
                .chain(b.keys().filter(|k| !a.contains_key(*k)))
                .filter(|k| a.get(*k) != b.get(*k))
                .map(|k| {
                    let show = |v: Option<&serde_json::Value>| {
                        let t = v.map_or("(none)".to_string(), |v| v.to_string());
                        match t.char_indices().nth(40) {
                            Some((i, _)) => format!("{}...", &t[..i]),
                            None => t,
                        }
                    };
                    format!("{k} {} -> {}", show(a.get(k)), show(b.get(k)))
                })
                .collect();
            if !changed.is_empty() {
                s += &format!(" (parameters that differ: {})", changed.join(", "));
            }
        }
        s
    }

    /// A one-line description for messages: `built-in pid`, `python planner m.Cls "name" version 2`.
    pub fn describe(&self) -> String {
        let mut s = match self.kind {
            PlannerSource::Builtin => format!("built-in {}", self.name),
            PlannerSource::Python => format!("python planner \"{}\"", self.name),
        };
        if let Some(c) = &self.class {
            s += &format!(" of class {c}");
        }
        if let Some(v) = &self.version {
            s += &format!(" version {v}");
        }
        if let Some(h) = &self.params_sha256 {
            let short: String = h.chars().take(12).collect();
            s += &format!(" with parameters sha256 {short}");
        }
        s
    }
}

/// The identity stored in `dir`, if any.
pub(crate) fn read(dir: &Path) -> Result<Option<PlannerIdentity>, EvalError> {
    let path = dir.join(IDENTITY_FILE);
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map(Some)
            .map_err(|e| io_err(&path, e)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_err(&path, e)),
    }
}

/// Stores `id` in `dir`.
pub(crate) fn write(dir: &Path, id: &PlannerIdentity) -> Result<(), EvalError> {
    let path = dir.join(IDENTITY_FILE);
    let text = serde_json::to_string_pretty(id).map_err(|e| io_err(&path, e))? + "\n";
    std::fs::write(&path, text).map_err(|e| io_err(&path, e))
}
