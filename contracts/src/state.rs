//! States of the service's episodes and submissions, and an episode's outcome as the service records it: each with
//! one string form (what the store holds and the APIs show), written by `as_str` and read by `parse`.

use crate::{EndReason, Outcome, UnknownName};
use serde::{Deserialize, Serialize};

named!(
    /// Where one episode of a submission is.
    EpisodeState, "episode state", {
        /// Waiting for a worker.
        Queued = "queued",
        /// A worker holds it (running, or waiting there for a slot).
        Leased = "leased",
        /// It has its result.
        Done = "done",
        /// Its submission was cancelled before it ran.
        NotRun = "not_run",
    }
);

named!(
    /// Where a submission is.
    SubmissionState, "submission state", {
        /// No episode of it has been leased yet.
        Queued = "queued",
        Running = "running",
        /// Every episode has its result.
        Done = "done",
        /// Cancelled: finished episodes kept, the rest not run.
        Cancelled = "cancelled",
    }
);

impl SubmissionState {
    /// Still queued or running.
    pub fn is_active(self) -> bool {
        matches!(self, Self::Queued | Self::Running)
    }
}

/// An episode's outcome as the service records it: the episode's own, or an infrastructure error (no worker could
/// run it; the episode is not the planner's failure).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RecordedOutcome {
    Episode(Outcome),
    InfrastructureError,
}

impl RecordedOutcome {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Episode(o) => o.as_str(),
            Self::InfrastructureError => "error",
        }
    }

    pub fn parse(s: &str) -> Result<RecordedOutcome, UnknownName> {
        if s == "error" {
            return Ok(Self::InfrastructureError);
        }
        Outcome::parse(s).map(Self::Episode)
    }

    /// The reason an end of this outcome has when nothing finer is known.
    pub fn plain_reason(self) -> EndReason {
        match self {
            Self::InfrastructureError => EndReason::Infrastructure,
            Self::Episode(o) => match o {
                Outcome::Success => EndReason::Success,
                Outcome::Rollover => EndReason::Rollover,
                Outcome::Stuck => EndReason::Stuck,
                Outcome::Timeout => EndReason::Timeout,
                Outcome::OffMap => EndReason::OffMap,
                Outcome::PlannerFailure => EndReason::PlannerError,
                Outcome::Cancelled => EndReason::Cancelled,
            },
        }
    }

    /// The episode failed because of the planner or the infrastructure, not by how it drove.
    pub fn is_failure_of_planner_or_infrastructure(self) -> bool {
        matches!(
            self,
            Self::InfrastructureError | Self::Episode(Outcome::PlannerFailure)
        )
    }
}

impl std::str::FromStr for RecordedOutcome {
    type Err = UnknownName;
    fn from_str(s: &str) -> Result<RecordedOutcome, UnknownName> {
        RecordedOutcome::parse(s)
    }
}

impl Serialize for RecordedOutcome {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.as_str())
    }
}

impl<'de> Deserialize<'de> for RecordedOutcome {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        RecordedOutcome::parse(&s).map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_value_round_trips_through_its_one_string_form() {
        for &s in EpisodeState::ALL {
            assert_eq!(EpisodeState::parse(s.as_str()), Ok(s));
            assert_eq!(serde_json::to_string(&s).ok(), Some(format!("\"{s}\"")));
        }
        for &s in SubmissionState::ALL {
            assert_eq!(SubmissionState::parse(s.as_str()), Ok(s));
        }
        for &o in Outcome::ALL {
            let r = RecordedOutcome::Episode(o);
            assert_eq!(RecordedOutcome::parse(r.as_str()), Ok(r));
        }
        assert_eq!(
            RecordedOutcome::parse("error"),
            Ok(RecordedOutcome::InfrastructureError)
        );
        let e = EpisodeState::parse("running").unwrap_err();
        assert_eq!(e.to_string(), "unknown episode state `running`");
        assert!(RecordedOutcome::parse("crashed").is_err());
        assert!(SubmissionState::Running.is_active() && !SubmissionState::Done.is_active());
    }
}
