//! How a submission gives its planner, typed: [`PlannerSpec`], and its one codec to and from the store's two
//! columns (`planner_kind` and `planner_spec`: a built-in's name, the endpoint's URL, the exec argv as a JSON list,
//! the image reference).

use crate::StoreError;
use contracts::{PlannerKind, PlannerName};

/// A submission's planner: what the worker is told to run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PlannerSpec {
    /// One of the benchmark's own planners, by name.
    Builtin(PlannerName),
    /// A planner server the submitter runs (its URL).
    Endpoint(String),
    /// A command the worker starts, in a sandbox.
    Exec(Vec<String>),
    /// A container image the worker runs.
    Image(String),
}

impl PlannerSpec {
    pub fn kind(&self) -> PlannerKind {
        match self {
            Self::Builtin(_) => PlannerKind::Builtin,
            Self::Endpoint(_) => PlannerKind::Endpoint,
            Self::Exec(_) => PlannerKind::Exec,
            Self::Image(_) => PlannerKind::Image,
        }
    }

    /// The `planner_spec` column's text.
    pub fn column(&self) -> String {
        match self {
            Self::Builtin(name) => name.to_string(),
            Self::Endpoint(url) => url.clone(),
            // A list of strings always serialises.
            Self::Exec(argv) => serde_json::to_string(argv).unwrap_or_default(),
            Self::Image(image) => image.clone(),
        }
    }

    /// The spec from the store's two columns; an exec spec that is not a JSON list of strings is a corrupt row.
    pub fn from_columns(kind: PlannerKind, spec: &str) -> Result<PlannerSpec, StoreError> {
        Ok(match kind {
            PlannerKind::Builtin => Self::Builtin(spec.into()),
            PlannerKind::Endpoint => Self::Endpoint(spec.into()),
            PlannerKind::Image => Self::Image(spec.into()),
            PlannerKind::Exec => Self::Exec(serde_json::from_str(spec).map_err(|e| {
                StoreError::Corrupt(format!("the stored exec planner is not a JSON argv: {e}"))
            })?),
        })
    }
}

/// `kind:spec`, as the service's status shows a submission's planner (`builtin:pid`, `exec:["python3","p.py"]`).
impl std::fmt::Display for PlannerSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}:{}", self.kind(), self.column())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_round_trip_and_a_corrupt_argv_is_said_so() {
        for spec in [
            PlannerSpec::Builtin("pid".into()),
            PlannerSpec::Endpoint("http://10.0.0.5:50051".into()),
            PlannerSpec::Exec(vec!["python3".into(), "my planner.py".into()]),
            PlannerSpec::Image("ghcr.io/lab/p@sha256:00".into()),
        ] {
            let back = PlannerSpec::from_columns(spec.kind(), &spec.column()).unwrap();
            assert_eq!(back, spec);
        }
        assert_eq!(
            PlannerSpec::Exec(vec!["a".into(), "b".into()]).to_string(),
            "exec:[\"a\",\"b\"]"
        );
        let err = PlannerSpec::from_columns(PlannerKind::Exec, "python3 p.py").unwrap_err();
        assert!(err.to_string().contains("not a JSON argv"), "{err}");
    }
}
