//! The benchmark's datasets (paper, section III-G): expert demonstrations, random exploration and failure cases,
//! generated on training worlds and written natively in LeRobot v3's layout (`FORMAT.md`).
//!
//! - [`record`]: one episode's metadata and frames, as generators make them and the writer takes them.
//! - [`spec`]: what a whole dataset is (kind, variant, vehicle, rates, versions, seed): its identity.
//! - [`generate`]: the episodes of the random, expert and failures datasets, on training worlds, into a sink.

pub mod generate;
pub mod record;
pub mod spec;

pub use record::{DatasetKind, EpisodeMeta, EpisodeRecord, FailureClass, FailureWindow, Frames};
pub use spec::{CropSpec, DatasetSpec, Variant};
