//! The benchmark's datasets (paper, section III-G): expert demonstrations, random exploration and failure cases,
//! generated on training worlds and written natively in LeRobot v3's layout (`FORMAT.md`).
//!
//! - [`record`]: one episode's metadata and frames, as generators make them and the writer takes them.
//! - [`spec`]: what a whole dataset is (kind, variant, vehicle, rates, versions, seed): its identity.
//! - [`generate`]: the episodes of the random, expert and failures datasets, on training worlds, into a sink
//!   ([`generate::EpisodeSink`], which [`DatasetWriter`] implements).
//! - [`writer`]: [`DatasetWriter`] writes a dataset directory, [`resume`] reopens one; [`card`] and [`plot`] make
//!   its `README.md` and pictures.
//! - [`validate()`]: checks a directory against the format and names what is wrong; [`info`] summarises it.
//! - The layout's pieces: [`layout`] (paths, atomic writes, directory scan), [`frames`] (the per-frame table),
//!   [`episodes`] (per-episode metadata, tasks), [`meta`] (`info.json`), [`stats`] (`stats.json`), [`json`],
//!   [`parquet_io`] and [`parquet_read`] (Parquet without Arrow).

pub mod card;
mod checks;
pub mod cli;
pub mod episodes;
pub mod error;
pub mod frames;
pub mod generate;
pub mod json;
pub mod layout;
pub mod meta;
pub mod parquet_io;
pub mod parquet_read;
pub mod plot;
pub mod record;
pub mod resume;
pub mod spec;
pub mod stats;
pub mod summary;
pub mod validate;
pub mod writer;

pub use error::DatasetError;
pub use record::{DatasetKind, EpisodeMeta, FailureClass, FailureWindow, Frames, RecordedEpisode};
pub use spec::{CropSpec, DatasetSpec, SpeedProfile, Variant};
pub use summary::info;
pub use validate::{validate, Problem, Report};
pub use writer::{DatasetWriter, ResumePoint, WriterOptions, WrittenDataset};
