//! The benchmark's vocabulary: a world's factors ([`ElevationLevel`], [`SemanticsKind`], [`ObstacleDensity`]), how
//! an episode ended ([`Outcome`] and its machine-readable [`EndReason`]) and how a submission names its planner
//! ([`PlannerKind`]). Each has one string form (`named!`), the one results files, the store and the APIs hold.

named!(
    /// Elevation level of a world: how much of the highest relief it uses (paper: 30 / 60 / 100 %).
    ElevationLevel, "elevation level", {
        Low = "low",
        Medium = "medium",
        High = "high",
    }
);

impl ElevationLevel {
    /// Fraction of the highest relief used by this level (paper: 30 / 60 / 100 %).
    pub fn fraction(self) -> f64 {
        match self {
            Self::Low => 0.3,
            Self::Medium => 0.6,
            Self::High => 1.0,
        }
    }
}

named!(
    /// Which kinds of surface a world has.
    SemanticsKind, "semantics", {
        Rigid = "rigid",
        Deformable = "deformable",
        Mixed = "mixed",
    }
);

named!(
    /// Obstacle density of a world (10 / 20 / 40 rocks).
    ObstacleDensity, "obstacle density", {
        Sparse = "sparse",
        Medium = "medium",
        Dense = "dense",
    }
);

named!(
    /// How an episode ended.
    Outcome, "outcome", {
        Success = "success",
        Rollover = "rollover",
        Stuck = "stuck",
        Timeout = "timeout",
        OffMap = "off_map",
        /// The planner failed (crash, timeout, NaN or out-of-range action); see the episode's [`EndReason`].
        PlannerFailure = "planner_failure",
        /// Its caller stopped it before it ended (an environment closed or reset mid-episode, a submission
        /// cancelled while the episode ran): neither a success nor a failure of the planner.
        Cancelled = "cancelled",
    }
);

impl Outcome {
    pub fn is_success(self) -> bool {
        self == Self::Success
    }
}

named!(
    /// Why an episode ended, finer than its [`Outcome`]: the planner's failures are told apart here.
    EndReason, "end reason", {
        Success = "success",
        Rollover = "rollover",
        Stuck = "stuck",
        /// The episode's time limit (gymnasium: truncated, not terminated).
        Timeout = "timeout",
        OffMap = "off_map",
        /// The simulation diverged (counted as a rollover).
        NumericalFailure = "numerical_failure",
        /// A NaN or out-of-range action.
        InvalidAction = "invalid_action",
        /// The planner did not answer in time.
        PlannerTimeout = "planner_timeout",
        /// The planner's process died.
        PlannerCrash = "planner_crash",
        /// The planner broke the protocol (a malformed or unexpected message).
        PlannerProtocol = "planner_protocol",
        /// The planner's endpoint could not be reached or connected to.
        PlannerUnreachable = "planner_unreachable",
        /// The planner reported an error.
        PlannerError = "planner_error",
        /// The caller stopped the episode ([`Outcome::Cancelled`]).
        Cancelled = "cancelled",
        /// No worker could run the episode (the service's infrastructure, not the planner).
        Infrastructure = "infrastructure",
    }
);

impl EndReason {
    /// What the public may read of why an episode ended: a sentence of the service's own, never the planner's
    /// output, program, image or URL (those go to the submission's owner only).
    pub fn public_sentence(self) -> &'static str {
        match self {
            Self::Success => "reached the goal",
            Self::Rollover => "the vehicle rolled over",
            Self::Stuck => "the vehicle stopped making progress",
            Self::Timeout => "the episode's time limit passed",
            Self::OffMap => "the vehicle left the map",
            Self::NumericalFailure => "the simulation diverged (counted as a rollover)",
            Self::InvalidAction => "the planner sent an invalid action (NaN or out of range)",
            Self::PlannerTimeout => "the planner did not answer within its deadline",
            Self::PlannerCrash => "the planner's process ended or could not start",
            Self::PlannerProtocol => "the planner broke the protocol",
            Self::PlannerUnreachable => "the planner could not be reached",
            Self::PlannerError => "the planner reported an error",
            Self::Cancelled => "the episode was cancelled",
            Self::Infrastructure => "no worker could run the episode",
        }
    }

    /// Whether the episode was truncated at its time limit rather than terminated (gymnasium's meanings).
    pub fn is_time_limit(self) -> bool {
        self == Self::Timeout
    }
}

named!(
    /// How a submission gives its planner: a built-in baseline by name, a gRPC endpoint it serves, a command the
    /// worker runs in a sandbox, or a container image.
    PlannerKind, "planner kind", {
        Builtin = "builtin",
        Endpoint = "endpoint",
        Exec = "exec",
        Image = "image",
    }
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Each value's string form is the one `as_str`, `Display`, `FromStr` and serde share, and no two values share one.
    fn one_form<T>(all: &[T])
    where
        T: Copy + PartialEq + std::fmt::Debug + std::fmt::Display + std::str::FromStr,
        T: serde::Serialize + serde::de::DeserializeOwned,
        <T as std::str::FromStr>::Err: std::fmt::Debug,
    {
        let mut seen = std::collections::BTreeSet::new();
        for &v in all {
            let s = v.to_string();
            assert!(seen.insert(s.clone()), "{s} twice");
            assert_eq!(s.parse::<T>().unwrap(), v);
            assert_eq!(serde_json::to_string(&v).unwrap(), format!("\"{s}\""));
            assert_eq!(serde_json::from_str::<T>(&format!("\"{s}\"")).unwrap(), v);
        }
    }

    #[test]
    fn every_value_has_one_string_form() {
        one_form(ElevationLevel::ALL);
        one_form(SemanticsKind::ALL);
        one_form(ObstacleDensity::ALL);
        one_form(Outcome::ALL);
        one_form(EndReason::ALL);
        one_form(PlannerKind::ALL);
        one_form(crate::Rules::ALL);
        let e = serde_json::from_str::<PlannerKind>("\"docker\"").unwrap_err();
        assert!(
            e.to_string().contains("unknown planner kind `docker`"),
            "{e}"
        );
    }

    #[test]
    fn only_the_time_limit_truncates() {
        let truncating: Vec<_> = EndReason::ALL
            .iter()
            .filter(|r| r.is_time_limit())
            .collect();
        assert_eq!(truncating, [&EndReason::Timeout]);
        // The summaries' failure mix and the files name these forms; they predate the types.
        let names: Vec<_> = Outcome::ALL.iter().map(|o| o.as_str()).collect();
        assert_eq!(
            names,
            [
                "success",
                "rollover",
                "stuck",
                "timeout",
                "off_map",
                "planner_failure",
                "cancelled"
            ]
        );
    }
}
