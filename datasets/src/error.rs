//! The crate's one error type: every variant names the file (or the episode and field) it is about.

use std::path::{Path, PathBuf};

/// What went wrong writing, resuming or reading a dataset.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A file or directory could not be created, written, renamed or read (full disk, no permission, ...).
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// A Parquet file could not be written or read, or is not what the format says it is.
    #[error("{path}: {message}")]
    Parquet { path: PathBuf, message: String },
    /// A JSON file that does not parse or lacks a field.
    #[error("{path}: {message}")]
    Json { path: PathBuf, message: String },
    /// The directory holds a dataset of another spec or writer options.
    #[error(
        "{path} holds another dataset ({}); write into another directory or remove it",
        .differences.join("; ")
    )]
    OtherDataset {
        path: PathBuf,
        differences: Vec<String>,
    },
    /// The directory holds files that are not part of a dataset.
    #[error(
        "{path} holds files that are not a dataset's ({}); write into an empty or new directory",
        .entries.join(", ")
    )]
    NotADataset { path: PathBuf, entries: Vec<String> },
    /// The dataset's completed files do not fit together (a gap, a file that does not match its metadata).
    #[error("{path}: {message}")]
    Damaged { path: PathBuf, message: String },
    /// An episode given to the writer is not consistent with itself or with the spec.
    #[error("episode {episode}: field `{field}`: {message}")]
    Record {
        episode: u64,
        field: String,
        message: String,
    },
    /// A writer option or spec field out of range.
    #[error("invalid `{field}`: {message}")]
    Invalid { field: String, message: String },
    /// The task set given for the card's pictures.
    #[error("task set: {0}")]
    TaskSet(String),
}

impl DatasetError {
    pub(crate) fn io(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        DatasetError::Io {
            path: path.as_ref().to_path_buf(),
            source,
        }
    }
    pub(crate) fn parquet(path: impl AsRef<Path>, message: impl ToString) -> Self {
        DatasetError::Parquet {
            path: path.as_ref().to_path_buf(),
            message: message.to_string(),
        }
    }
    pub(crate) fn json(path: impl AsRef<Path>, message: impl ToString) -> Self {
        DatasetError::Json {
            path: path.as_ref().to_path_buf(),
            message: message.to_string(),
        }
    }
    pub(crate) fn damaged(path: impl AsRef<Path>, message: impl ToString) -> Self {
        DatasetError::Damaged {
            path: path.as_ref().to_path_buf(),
            message: message.to_string(),
        }
    }
    pub(crate) fn record(episode: u64, field: &str, message: impl ToString) -> Self {
        DatasetError::Record {
            episode,
            field: field.to_string(),
            message: message.to_string(),
        }
    }
    pub(crate) fn invalid(field: &str, message: impl ToString) -> Self {
        DatasetError::Invalid {
            field: field.to_string(),
            message: message.to_string(),
        }
    }
}
