//! The one mapping between the protocol's enums and messages and the benchmark's vocabulary (crate `contracts`):
//! each contracts enum converts to its protobuf enum (`From`) and back (`TryFrom`, refusing `UNSPECIFIED`), and
//! [`pb::Metrics`] carries [`EpisodeMetrics`] field for field (each `f64` copied bit for bit).
//!
//! A message's enum field is an `i32` on the wire: [`ProtoEnum::from_wire`] reads one (an unknown number or
//! `UNSPECIFIED` is a [`ConvertError`], which becomes `INVALID_ARGUMENT`), [`ProtoEnum::wire`] writes one.

use crate::v1 as pb;
use contracts::{
    ElevationLevel, EndReason, EpisodeMetrics, EpisodeState, ObstacleDensity, Outcome,
    RecordedOutcome, Rules, SemanticsKind, SignalStats, SubmissionState,
};

/// A protobuf enum value that names no value of the vocabulary.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ConvertError {
    /// `UNSPECIFIED` (0): the field was not set.
    #[error("no {what} given (unspecified)")]
    Unspecified { what: &'static str },
    /// A number the protocol does not define (a newer or broken peer).
    #[error("unknown {what} number {value}")]
    Unknown { what: &'static str, value: i32 },
}

impl From<ConvertError> for tonic::Status {
    fn from(e: ConvertError) -> tonic::Status {
        tonic::Status::invalid_argument(e.to_string())
    }
}

/// A vocabulary enum with its protobuf enum.
pub trait ProtoEnum: Copy + Sized {
    /// The generated protobuf enum.
    type Proto: Copy + Into<i32> + TryFrom<i32>;
    /// What a value is, for errors ("elevation level").
    const WHAT: &'static str;

    fn to_proto(self) -> Self::Proto;

    /// The value of `p`; `UNSPECIFIED` is an error.
    fn from_proto(p: Self::Proto) -> Result<Self, ConvertError>;

    /// The number a message carries for `self`.
    fn wire(self) -> i32 {
        self.to_proto().into()
    }

    /// The value a message's number names: an unknown number or `UNSPECIFIED` is an error.
    fn from_wire(value: i32) -> Result<Self, ConvertError> {
        let p = Self::Proto::try_from(value).map_err(|_| ConvertError::Unknown {
            what: Self::WHAT,
            value,
        })?;
        Self::from_proto(p)
    }
}

/// `From`/`TryFrom` and [`ProtoEnum`] between a contracts enum and its protobuf enum, value for value.
macro_rules! proto_enum {
    ($c:ident, $p:ident, $what:literal, { $($cv:ident => $pv:ident),+ $(,)? }) => {
        impl From<$c> for pb::$p {
            fn from(v: $c) -> pb::$p {
                match v {
                    $($c::$cv => pb::$p::$pv),+
                }
            }
        }

        impl TryFrom<pb::$p> for $c {
            type Error = ConvertError;
            fn try_from(p: pb::$p) -> Result<$c, ConvertError> {
                match p {
                    $(pb::$p::$pv => Ok($c::$cv),)+
                    pb::$p::Unspecified => Err(ConvertError::Unspecified { what: $what }),
                }
            }
        }

        proto_enum!(@trait $c, $p, $what);
    };
    (@trait $c:ident, $p:ident, $what:literal) => {
        impl ProtoEnum for $c {
            type Proto = pb::$p;
            const WHAT: &'static str = $what;
            fn to_proto(self) -> pb::$p {
                self.into()
            }
            fn from_proto(p: pb::$p) -> Result<$c, ConvertError> {
                p.try_into()
            }
        }
    };
}

proto_enum!(ElevationLevel, ElevationLevel, "elevation level", {
    Low => Low,
    Medium => Medium,
    High => High,
});

proto_enum!(SemanticsKind, SemanticsKind, "semantics", {
    Rigid => Rigid,
    Deformable => Deformable,
    Mixed => Mixed,
});

proto_enum!(ObstacleDensity, ObstacleDensity, "obstacle density", {
    Sparse => Sparse,
    Medium => Medium,
    Dense => Dense,
});

proto_enum!(EpisodeState, EpisodeState, "episode state", {
    Queued => Queued,
    Leased => Leased,
    Done => Done,
    NotRun => NotRun,
});

proto_enum!(SubmissionState, SubmissionState, "submission state", {
    Queued => Queued,
    Running => Running,
    Done => Done,
    Cancelled => Cancelled,
});

impl From<RecordedOutcome> for pb::Outcome {
    fn from(o: RecordedOutcome) -> pb::Outcome {
        match o {
            RecordedOutcome::Episode(o) => o.into(),
            RecordedOutcome::InfrastructureError => pb::Outcome::InfrastructureError,
        }
    }
}

impl TryFrom<pb::Outcome> for RecordedOutcome {
    type Error = ConvertError;
    fn try_from(p: pb::Outcome) -> Result<RecordedOutcome, ConvertError> {
        use RecordedOutcome::Episode;
        Ok(match p {
            pb::Outcome::Success => Episode(Outcome::Success),
            pb::Outcome::Rollover => Episode(Outcome::Rollover),
            pb::Outcome::Stuck => Episode(Outcome::Stuck),
            pb::Outcome::Timeout => Episode(Outcome::Timeout),
            pb::Outcome::OffMap => Episode(Outcome::OffMap),
            pb::Outcome::PlannerFailure => Episode(Outcome::PlannerFailure),
            pb::Outcome::Cancelled => Episode(Outcome::Cancelled),
            pb::Outcome::InfrastructureError => RecordedOutcome::InfrastructureError,
            pb::Outcome::Unspecified => return Err(ConvertError::Unspecified { what: "outcome" }),
        })
    }
}

proto_enum!(@trait RecordedOutcome, Outcome, "outcome");

/// An episode's own outcome (never `INFRASTRUCTURE_ERROR`).
impl From<Outcome> for pb::Outcome {
    fn from(o: Outcome) -> pb::Outcome {
        match o {
            Outcome::Success => pb::Outcome::Success,
            Outcome::Rollover => pb::Outcome::Rollover,
            Outcome::Stuck => pb::Outcome::Stuck,
            Outcome::Timeout => pb::Outcome::Timeout,
            Outcome::OffMap => pb::Outcome::OffMap,
            Outcome::PlannerFailure => pb::Outcome::PlannerFailure,
            Outcome::Cancelled => pb::Outcome::Cancelled,
        }
    }
}

proto_enum!(EndReason, EndReason, "end reason", {
    Success => Success,
    Rollover => Rollover,
    Stuck => Stuck,
    Timeout => Timeout,
    OffMap => OffMap,
    NumericalFailure => NumericalFailure,
    InvalidAction => InvalidAction,
    PlannerTimeout => PlannerTimeout,
    PlannerCrash => PlannerCrash,
    PlannerProtocol => PlannerProtocol,
    PlannerUnreachable => PlannerUnreachable,
    PlannerError => PlannerError,
    Cancelled => Cancelled,
    Infrastructure => Infrastructure,
});

proto_enum!(Rules, Rules, "rules", {
    Paper => Paper,
    Release => Release,
    Custom => Custom,
});

impl From<SignalStats> for pb::SignalStats {
    fn from(s: SignalStats) -> pb::SignalStats {
        let SignalStats { mean, var, max } = s;
        pb::SignalStats {
            mean: Some(mean),
            var: Some(var),
            max: Some(max),
        }
    }
}

impl From<pb::SignalStats> for SignalStats {
    fn from(s: pb::SignalStats) -> SignalStats {
        let pb::SignalStats { mean, var, max } = s;
        SignalStats {
            mean: mean.unwrap_or(0.0),
            var: var.unwrap_or(0.0),
            max: max.unwrap_or(0.0),
        }
    }
}

impl From<&EpisodeMetrics> for pb::Metrics {
    fn from(m: &EpisodeMetrics) -> pb::Metrics {
        // Destructured, so a metric added to EpisodeMetrics fails to compile here until the protocol carries it.
        let EpisodeMetrics {
            time,
            roll,
            roll_abs,
            pitch,
            pitch_abs,
            throttle_mean,
            throttle_var,
            throttle_tv,
            steering_mean,
            steering_var,
            steering_tv,
            path_length,
            energy,
            obstacle_contacts,
            final_goal_distance,
            steps,
        } = *m;
        pb::Metrics {
            time: Some(time),
            roll: Some(roll.into()),
            roll_abs: Some(roll_abs.into()),
            pitch: Some(pitch.into()),
            pitch_abs: Some(pitch_abs.into()),
            throttle_mean: Some(throttle_mean),
            throttle_var: Some(throttle_var),
            throttle_tv: Some(throttle_tv),
            steering_mean: Some(steering_mean),
            steering_var: Some(steering_var),
            steering_tv: Some(steering_tv),
            path_length: Some(path_length),
            energy: Some(energy),
            obstacle_contacts,
            final_goal_distance: Some(final_goal_distance),
            steps,
        }
    }
}

impl From<EpisodeMetrics> for pb::Metrics {
    fn from(m: EpisodeMetrics) -> pb::Metrics {
        (&m).into()
    }
}

/// A missing metric or signal reads as zero, as one missing from stored JSON does.
impl From<pb::Metrics> for EpisodeMetrics {
    fn from(m: pb::Metrics) -> EpisodeMetrics {
        let pb::Metrics {
            time,
            roll,
            roll_abs,
            pitch,
            pitch_abs,
            throttle_mean,
            throttle_var,
            throttle_tv,
            steering_mean,
            steering_var,
            steering_tv,
            path_length,
            energy,
            obstacle_contacts,
            final_goal_distance,
            steps,
        } = m;
        let stats = |s: Option<pb::SignalStats>| s.map(SignalStats::from).unwrap_or_default();
        EpisodeMetrics {
            time: time.unwrap_or(0.0),
            roll: stats(roll),
            roll_abs: stats(roll_abs),
            pitch: stats(pitch),
            pitch_abs: stats(pitch_abs),
            throttle_mean: throttle_mean.unwrap_or(0.0),
            throttle_var: throttle_var.unwrap_or(0.0),
            throttle_tv: throttle_tv.unwrap_or(0.0),
            steering_mean: steering_mean.unwrap_or(0.0),
            steering_var: steering_var.unwrap_or(0.0),
            steering_tv: steering_tv.unwrap_or(0.0),
            path_length: path_length.unwrap_or(0.0),
            energy: energy.unwrap_or(0.0),
            obstacle_contacts,
            final_goal_distance: final_goal_distance.unwrap_or(0.0),
            steps,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use prost::Message;

    /// Every value goes to a distinct, specified protobuf number and comes back; `UNSPECIFIED` and unknown numbers
    /// are refused.
    fn round_trips<T: ProtoEnum + PartialEq + std::fmt::Debug>(all: &[T]) {
        let mut seen = std::collections::BTreeSet::new();
        for &v in all {
            let n = v.wire();
            assert_ne!(n, 0, "{v:?} is UNSPECIFIED");
            assert!(seen.insert(n), "{v:?}: number {n} twice");
            assert_eq!(T::from_wire(n), Ok(v));
            assert_eq!(T::from_proto(v.to_proto()), Ok(v));
        }
        // The protobuf enum has no other value (the tables' matches are exhaustive both ways, so this holds by
        // construction; it fails if a value is numbered past the range checked).
        let defined = (0..256).filter(|&n| T::Proto::try_from(n).is_ok()).count();
        assert_eq!(
            defined,
            all.len() + 1,
            "{}: values besides UNSPECIFIED",
            T::WHAT
        );
        assert_eq!(
            T::from_wire(0),
            Err(ConvertError::Unspecified { what: T::WHAT })
        );
        assert_eq!(
            T::from_wire(1000),
            Err(ConvertError::Unknown {
                what: T::WHAT,
                value: 1000
            })
        );
        assert_eq!(
            T::from_wire(-1),
            Err(ConvertError::Unknown {
                what: T::WHAT,
                value: -1
            })
        );
    }

    #[test]
    fn every_value_round_trips_and_unspecified_is_refused() {
        round_trips(ElevationLevel::ALL);
        round_trips(SemanticsKind::ALL);
        round_trips(ObstacleDensity::ALL);
        round_trips(EpisodeState::ALL);
        round_trips(SubmissionState::ALL);
        round_trips(EndReason::ALL);
        round_trips(Rules::ALL);
        let recorded: Vec<_> = Outcome::ALL
            .iter()
            .map(|&o| RecordedOutcome::Episode(o))
            .chain([RecordedOutcome::InfrastructureError])
            .collect();
        round_trips(&recorded);
        for &o in Outcome::ALL {
            assert_eq!(pb::Outcome::from(o), RecordedOutcome::Episode(o).to_proto());
        }
        let e = tonic::Status::from(ConvertError::Unspecified { what: "outcome" });
        assert_eq!(e.code(), tonic::Code::InvalidArgument);
        assert_eq!(e.message(), "no outcome given (unspecified)");
    }

    /// Awkward values (the last bits of a float that JSON once lost, negative zero, infinities, NaN with a payload)
    /// come back bit for bit, through the struct and through the wire (negative zero included: an implicit-presence
    /// double equal to zero would be left off the wire).
    #[test]
    fn metrics_round_trip_bit_for_bit() {
        let mut m = EpisodeMetrics {
            time: 28.768000000002946,
            throttle_mean: -0.0,
            throttle_var: f64::MIN_POSITIVE / 2.0,
            throttle_tv: 3.9066006773336635,
            steering_mean: 0.47018710466033653,
            steering_var: f64::INFINITY,
            steering_tv: f64::NEG_INFINITY,
            path_length: f64::from_bits(0x7ff8_0000_dead_beef),
            energy: 1.0e300,
            obstacle_contacts: u32::MAX,
            final_goal_distance: 9.992706353594361,
            steps: u64::MAX,
            ..Default::default()
        };
        m.roll = SignalStats {
            mean: 1.0,
            var: 13.808526635729677,
            max: 2.5,
        };
        m.roll_abs.max = 7.0;
        m.pitch.mean = -2.0042475476114894;
        m.pitch_abs.var = 1e-310;
        m.pitch_abs.max = -0.0;
        let bits = |m: &EpisodeMetrics| {
            let s = |s: &SignalStats| [s.mean.to_bits(), s.var.to_bits(), s.max.to_bits()];
            (
                [
                    m.time,
                    m.throttle_mean,
                    m.throttle_var,
                    m.throttle_tv,
                    m.steering_mean,
                    m.steering_var,
                    m.steering_tv,
                    m.path_length,
                    m.energy,
                    m.final_goal_distance,
                ]
                .map(f64::to_bits),
                [s(&m.roll), s(&m.roll_abs), s(&m.pitch), s(&m.pitch_abs)],
                m.obstacle_contacts,
                m.steps,
            )
        };
        let p = pb::Metrics::from(&m);
        let back = EpisodeMetrics::from(p);
        assert_eq!(bits(&back), bits(&m));
        let wire = pb::Metrics::decode(p.encode_to_vec().as_slice()).unwrap();
        assert_eq!(bits(&EpisodeMetrics::from(wire)), bits(&m));
        let zero = EpisodeMetrics::from(pb::Metrics::default());
        assert_eq!(zero, EpisodeMetrics::default());
    }
}
