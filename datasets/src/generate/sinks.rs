//! The dataset writer as a sink, and where a run continues after what its writers hold.
//!
//! A writer keeps only completed files, so after an interruption the main and the failures datasets may end at
//! different episodes. [`Resume::from_writers`] reads each one's last completed episode (its seed gives its index,
//! [`super::episode_index`]), so the resumed run appends to each exactly what the uninterrupted run would have.

use super::failures::source_name;
use super::{episode_index, EpisodeSink, GenerateConfig, GenerateError, Resume, SinkError};
use crate::episodes::read_episodes;
use crate::layout::scan;
use crate::record::{DatasetKind, EpisodeMeta, RecordedEpisode};
use crate::writer::DatasetWriter;

impl EpisodeSink for DatasetWriter {
    fn append(&mut self, rec: &RecordedEpisode) -> Result<(), SinkError> {
        DatasetWriter::append(self, rec).map_err(Into::into)
    }
}

/// The last completed episode of `w`'s dataset for which `keep` holds, and the frames of all those episodes (call
/// after [`DatasetWriter::open`], which removes what an interrupted run left unfinished).
pub fn completed(
    w: &DatasetWriter,
    keep: &dyn Fn(&EpisodeMeta) -> bool,
) -> Result<(Option<EpisodeMeta>, u64), GenerateError> {
    let dir = w.dir();
    let (mut last, mut frames) = (None, 0);
    for id in scan(dir)?.episodes {
        for r in read_episodes(&dir.join(id.episodes()), w.spec())? {
            if keep(&r.meta) {
                frames += r.length;
                last = Some(r.meta);
            }
        }
    }
    Ok((last, frames))
}

impl Resume {
    /// Where a run of `cfg` continues after what `main` (its main dataset) and `failures` (the failures dataset
    /// it feeds, if any) hold. The failures dataset may also hold the windows of other runs (random, expert,
    /// evaluations): only the windows of this run's source ([`source_name`]) and seed count.
    pub fn from_writers(
        cfg: &GenerateConfig,
        main: &DatasetWriter,
        failures: Option<&DatasetWriter>,
    ) -> Result<Resume, GenerateError> {
        // An index far beyond any run's length means the episode is another run's (another seed).
        let this_seed = |m: &EpisodeMeta| episode_index(cfg.seed, m.seed) < 1 << 48;
        let source_of = |m: &EpisodeMeta| m.failure.as_ref().map(|f| f.source.clone());
        let eval_sources: Vec<String> = cfg
            .planners
            .iter()
            .map(|p| source_name(DatasetKind::Failures, p))
            .collect();
        let main_ours = |m: &EpisodeMeta| {
            this_seed(m)
                && (cfg.kind != DatasetKind::Failures
                    || source_of(m).is_some_and(|s| eval_sources.contains(&s)))
        };
        let (main_last, main_frames) = completed(main, &main_ours)?;
        let planner = cfg.planners.first().map_or("", String::as_str);
        let source = source_name(cfg.kind, planner);
        let window_ours = |m: &EpisodeMeta| this_seed(m) && source_of(m).as_ref() == Some(&source);
        let failures_last = match failures {
            Some(w) if cfg.kind != DatasetKind::Failures => completed(w, &window_ours)?.0,
            _ => None,
        };
        Ok(Resume::from_sinks(
            cfg,
            main_last.as_ref(),
            main_frames,
            failures_last.as_ref(),
        ))
    }
}
