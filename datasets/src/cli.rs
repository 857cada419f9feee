//! Library side of `vb dataset generate`: opens (or resumes) the dataset directories, runs the generator into
//! them and finishes them (meta files and card), so the binary only parses options.

use crate::generate::{failures_spec, run, spec, EpisodeSink, GenerateConfig, GenerateError};
use crate::generate::{GenerateProgress, GenerateSummary, Resume};
use crate::{DatasetKind, DatasetWriter, WriterOptions, WrittenDataset};
use std::path::Path;

/// What `vb dataset generate` did.
#[derive(Clone, Debug)]
pub struct Generated {
    pub run: GenerateSummary,
    /// The main dataset, and the failure windows' dataset when one was asked for.
    pub main: WrittenDataset,
    pub failures: Option<WrittenDataset>,
}

fn options(cfg: &GenerateConfig) -> Result<WriterOptions, GenerateError> {
    Ok(WriterOptions {
        task_set: Some(tasks::TaskSet::load(&cfg.task_dir)?),
        ..WriterOptions::default()
    })
}

/// Generates `cfg` into `out` (and, for random and expert runs with `failures_out`, their failure windows there),
/// resuming whatever an earlier run with the same arguments left in them. `command` is recorded in the datasets.
pub fn generate(
    cfg: &GenerateConfig,
    out: &Path,
    failures_out: Option<&Path>,
    command: &str,
    progress: &dyn Fn(&GenerateProgress),
) -> Result<Generated, GenerateError> {
    if cfg.kind == DatasetKind::Failures && failures_out.is_some() {
        return Err(GenerateError::Param {
            field: "failures-out".into(),
            message: "a failures run writes its windows to --out".into(),
        });
    }
    let mut main = DatasetWriter::open_with(out, &spec(cfg)?, command, options(cfg)?)?;
    let mut failures = match failures_out {
        Some(dir) => Some(DatasetWriter::open_with(
            dir,
            &failures_spec(cfg)?,
            command,
            options(cfg)?,
        )?),
        None => None,
    };
    let resume = Resume::from_writers(cfg, &main, failures.as_ref())?;
    let feed = failures.as_mut().map(|f| f as &mut dyn EpisodeSink);
    let summary = run(cfg, &resume, &mut main, feed, progress)?;
    Ok(Generated {
        run: summary,
        main: main.finish()?,
        failures: failures.map(DatasetWriter::finish).transpose()?,
    })
}
