//! [`DatasetWriter`]: writes episodes into a LeRobot v3 dataset directory, resumably.
//!
//! Episodes are buffered into the current data file; once its frames reach `data_files_size_in_mb` (uncompressed)
//! the file is written (temporary name, renamed when complete), then its episodes' metadata file, then
//! `meta/info.json`, `stats.json` and `tasks.parquet` for the completed part (so a partial dataset is readable).
//! [`DatasetWriter::finish`] writes the last file, the metadata and the card, and marks the dataset complete.
//! Episodes never span files; file boundaries depend on the frames alone, so an interrupted and resumed run gives
//! the same bytes as an uninterrupted one.

use crate::card::{write_card, CardInput};
use crate::episodes::{task_string, write_episodes, write_tasks, EpisodeMetaRow};
use crate::error::DatasetError;
use crate::frames::{check_record, row_bytes, FrameColumns};
use crate::layout::{write_atomic, FileId, INFO, STATS, TASKS};
use crate::meta::{checksum, info, Layout, Totals, VertibenchInfo, FORMAT};
use crate::parquet_io::write_table;
use crate::plot::CardData;
use crate::record::RecordedEpisode;
use crate::resume::{load, KEY_COMMAND, KEY_LAYOUT, KEY_SPEC};
use crate::spec::{DatasetSpec, Variant};
use crate::stats::Stats;
use contracts::Outcome;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How the writer lays out files, and what the card draws on.
#[derive(Clone, Debug)]
pub struct WriterOptions {
    /// A data file is closed once its frames reach this many MB (10^6 bytes) uncompressed (LeRobot's default 100).
    pub data_files_size_in_mb: f64,
    /// Files per `chunk-NNN` directory (LeRobot's default 1000).
    pub chunks_size: u64,
    /// The task set the episodes ran on: the card draws the driven paths over its maps. Its version must be the
    /// spec's `task_set_version`.
    pub task_set: Option<tasks::TaskSet>,
}

impl Default for WriterOptions {
    fn default() -> Self {
        WriterOptions {
            data_files_size_in_mb: 100.0,
            chunks_size: 1000,
            task_set: None,
        }
    }
}

/// How much of a dataset is complete: a generator continues from episode index `episodes`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResumePoint {
    pub episodes: u64,
    pub frames: u64,
    pub simulated_seconds: f64,
}

/// What a finished dataset holds.
#[derive(Clone, Debug, PartialEq)]
pub struct WrittenDataset {
    pub dir: PathBuf,
    pub episodes: u64,
    pub frames: u64,
    pub data_files: u64,
    pub tasks: u64,
    pub simulated_hours: f64,
    /// Episodes by outcome (`Outcome::as_str`).
    pub outcomes: BTreeMap<String, u64>,
    /// Where this run started ([`DatasetWriter::resume_point`] at open).
    pub resumed_from: ResumePoint,
}

/// Writes one dataset directory. Not `Sync`: append from one thread, in episode order.
pub struct DatasetWriter {
    root: PathBuf,
    spec: DatasetSpec,
    layout: Layout,
    task_set: Option<tasks::TaskSet>,
    command: String,
    episodes: Vec<EpisodeMetaRow>,
    files: u64,
    tasks: Vec<String>,
    stats: Stats,
    card: CardData,
    pending: FrameColumns,
    pending_rows: Vec<EpisodeMetaRow>,
    /// [`crate::meta::VertibenchInfo::checksums`] of the completed files.
    checksums: BTreeMap<String, String>,
    /// `info.json` on disk says complete (a finished dataset reopened).
    info_complete: bool,
    /// Set by a failed write: the writer refuses further work (the directory stays resumable).
    failed: Option<String>,
    resumed_from: ResumePoint,
}

fn check_spec(spec: &DatasetSpec, o: &WriterOptions) -> Result<(), DatasetError> {
    let bad = |f: &str, m: &str| Err(DatasetError::invalid(f, m));
    if spec.wheels == 0 {
        return bad("wheels", "a vehicle has at least one wheel (track contact)");
    }
    if !(spec.control_rate_hz.is_finite() && spec.control_rate_hz > 0.0) {
        return bad("control_rate_hz", "must be a positive number");
    }
    if !(spec.scale.is_finite() && spec.scale > 0.0) {
        return bad("scale", "must be a positive number");
    }
    if spec.variant == Variant::Full && spec.crop.size == 0 {
        return bad(
            "crop.size",
            "the full variant stores crops of at least 1 x 1 cells",
        );
    }
    if !(o.data_files_size_in_mb.is_finite() && o.data_files_size_in_mb > 0.0) {
        return bad("data_files_size_in_mb", "must be a positive number");
    }
    if o.chunks_size == 0 {
        return bad("chunks_size", "must be at least 1");
    }
    Ok(())
}

impl DatasetWriter {
    /// Opens `dir` for `spec` with the default options ([`WriterOptions::default`]).
    pub fn open(
        dir: &Path,
        spec: &DatasetSpec,
        command: &str,
    ) -> Result<DatasetWriter, DatasetError> {
        Self::open_with(dir, spec, command, WriterOptions::default())
    }

    /// Creates a dataset in `dir` (made if missing), or resumes the one there if it has the same spec and layout
    /// options. Refuses a directory holding another dataset (naming the fields that differ), files that are not a
    /// dataset's, or a dataset whose completed files do not fit together. `command` (the command line, without
    /// options that do not change the content, such as a thread count) goes into `info.json` and the card; a
    /// resumed dataset keeps the one it was started with.
    pub fn open_with(
        dir: &Path,
        spec: &DatasetSpec,
        command: &str,
        options: WriterOptions,
    ) -> Result<DatasetWriter, DatasetError> {
        check_spec(spec, &options)?;
        std::fs::create_dir_all(dir).map_err(|e| DatasetError::io(dir, e))?;
        let layout = Layout {
            data_files_size_in_mb: options.data_files_size_in_mb,
            chunks_size: options.chunks_size,
        };
        let existing = load(dir, spec, &layout)?;
        let mut w = DatasetWriter {
            root: dir.to_path_buf(),
            spec: spec.clone(),
            layout,
            task_set: options.task_set,
            command: command.to_string(),
            episodes: Vec::new(),
            files: 0,
            tasks: Vec::new(),
            stats: Stats::new(spec),
            card: CardData::default(),
            pending: FrameColumns::new(spec),
            pending_rows: Vec::new(),
            checksums: BTreeMap::new(),
            info_complete: false,
            failed: None,
            resumed_from: ResumePoint::default(),
        };
        match existing {
            None => w.write_info(false)?,
            Some(e) => {
                if let Some(c) = e.command {
                    w.command = c;
                }
                w.episodes = e.episodes;
                w.files = e.files;
                w.tasks = e.tasks;
                w.stats = e.stats;
                w.card = e.card;
                w.checksums = e.checksums;
                w.info_complete = e.complete;
                if !e.complete {
                    // Brings meta/ up to the completed files (it may be missing or behind after a crash).
                    w.write_meta(false)?;
                }
            }
        }
        w.resumed_from = w.resume_point();
        Ok(w)
    }

    /// The dataset's directory.
    pub fn dir(&self) -> &Path {
        &self.root
    }

    pub fn spec(&self) -> &DatasetSpec {
        &self.spec
    }

    /// How much is complete on disk (episodes appended since the last completed data file are not counted).
    pub fn resume_point(&self) -> ResumePoint {
        let frames = self.episodes.last().map_or(0, |e| e.to);
        ResumePoint {
            episodes: self.episodes.len() as u64,
            frames,
            simulated_seconds: frames as f64 / self.spec.control_rate_hz,
        }
    }

    fn usable(&self) -> Result<(), DatasetError> {
        match &self.failed {
            None => Ok(()),
            Some(m) => Err(DatasetError::invalid(
                "writer",
                format!("an earlier write failed ({m}); reopen the directory to resume"),
            )),
        }
    }

    /// Appends the next episode (index [`ResumePoint::episodes`] plus the episodes appended since). A record
    /// inconsistent with itself or the spec is refused with [`DatasetError::Record`] and nothing of it is kept;
    /// a failed write leaves the directory resumable and the writer refusing further calls.
    pub fn append(&mut self, rec: &RecordedEpisode) -> Result<(), DatasetError> {
        self.usable()?;
        let index = (self.episodes.len() + self.pending_rows.len()) as u64;
        check_record(rec, &self.spec, index)?;
        let task = task_string(&rec.meta);
        let task_index = match self.tasks.iter().position(|t| *t == task) {
            Some(i) => i,
            None => {
                self.tasks.push(task.clone());
                self.tasks.len() - 1
            }
        } as u64;
        let from = self
            .pending_rows
            .last()
            .or(self.episodes.last())
            .map_or(0, |e| e.to);
        let length = rec.frames.len() as u64;
        self.pending
            .push(rec, index, from, task_index, self.spec.control_rate_hz);
        self.pending_rows.push(EpisodeMetaRow {
            index,
            meta: rec.meta.clone(),
            length,
            task,
            file: FileId::nth(self.files, self.layout.chunks_size),
            from,
            to: from + length,
        });
        let limit = self.layout.data_files_size_in_mb * 1e6;
        if (self.pending.rows as u64 * row_bytes(&self.spec)) as f64 >= limit {
            self.commit()?;
        }
        Ok(())
    }

    fn footer(&self) -> Vec<(String, String)> {
        let j = |v: Result<String, serde_json::Error>| v.unwrap_or_default();
        vec![
            (KEY_SPEC.into(), j(serde_json::to_string(&self.spec))),
            (KEY_LAYOUT.into(), j(serde_json::to_string(&self.layout))),
            (KEY_COMMAND.into(), self.command.clone()),
        ]
    }

    fn commit(&mut self) -> Result<(), DatasetError> {
        if self.pending_rows.is_empty() {
            return Ok(());
        }
        let r = self.commit_file();
        if let Err(e) = &r {
            self.failed = Some(e.to_string());
        }
        r
    }

    fn commit_file(&mut self) -> Result<(), DatasetError> {
        if self.info_complete {
            // A finished dataset grows: say it is not finished before its files change.
            self.write_info(false)?;
            self.info_complete = false;
        }
        let id = FileId::nth(self.files, self.layout.chunks_size);
        let footer = self.footer();
        let frames = std::mem::replace(&mut self.pending, FrameColumns::new(&self.spec));
        let mut stats = self.stats.clone();
        stats.add(&frames);
        let mut card = self.card.clone();
        card.add(&frames, &self.pending_rows);
        let data = self.root.join(id.data());
        let bytes = write_table(&data, frames.into_columns(&self.spec), &footer)?;
        write_atomic(&data, &bytes)?;
        self.checksums.insert(id.data(), checksum(&bytes));
        let eps = self.root.join(id.episodes());
        let bytes = write_episodes(&eps, &self.spec, &self.pending_rows, &footer)?;
        write_atomic(&eps, &bytes)?;
        self.checksums.insert(id.episodes(), checksum(&bytes));
        self.episodes.append(&mut self.pending_rows);
        self.files += 1;
        self.stats = stats;
        self.card = card;
        self.write_meta(false)
    }

    fn totals(&self) -> Totals {
        let frames = self.episodes.last().map_or(0, |e| e.to);
        let seconds = frames as f64 / self.spec.control_rate_hz;
        Totals {
            episodes: self.episodes.len() as u64,
            frames,
            data_files: self.files,
            simulated_seconds: seconds,
            simulated_hours: seconds / 3600.0,
        }
    }

    fn write_info(&self, complete: bool) -> Result<(), DatasetError> {
        let path = self.root.join(INFO);
        let i = info(
            VertibenchInfo {
                format: FORMAT.into(),
                complete,
                spec: self.spec.clone(),
                command: self.command.clone(),
                layout: self.layout.clone(),
                totals: self.totals(),
                checksums: self.checksums.clone(),
            },
            self.tasks.len() as u64,
        );
        write_atomic(&path, &crate::json::to_bytes(&path, &i)?)
    }

    /// `tasks.parquet` and `stats.json`, their checksums kept for `info.json`.
    fn write_tasks_and_stats(&mut self) -> Result<(), DatasetError> {
        let tasks = self.root.join(TASKS);
        let bytes = write_tasks(&tasks, &self.tasks)?;
        write_atomic(&tasks, &bytes)?;
        self.checksums.insert(TASKS.into(), checksum(&bytes));
        let stats = self.root.join(STATS);
        let bytes = self.stats.to_bytes(&stats)?;
        write_atomic(&stats, &bytes)?;
        self.checksums.insert(STATS.into(), checksum(&bytes));
        Ok(())
    }

    /// `tasks.parquet`, `stats.json`, then `info.json` (last: it says what the others describe).
    fn write_meta(&mut self, complete: bool) -> Result<(), DatasetError> {
        self.write_tasks_and_stats()?;
        self.write_info(complete)
    }

    /// Writes the last data file, the metadata and the card, and marks the dataset complete.
    pub fn finish(mut self) -> Result<WrittenDataset, DatasetError> {
        self.usable()?;
        self.commit()?;
        let totals = self.totals();
        self.write_tasks_and_stats()?;
        write_card(
            &self.root,
            &CardInput {
                spec: &self.spec,
                command: &self.command,
                layout: &self.layout,
                totals: &totals,
                episodes: &self.episodes,
                tasks: &self.tasks,
                data: &self.card,
                task_set: self.task_set.as_ref(),
            },
        )?;
        self.write_info(true)?;
        let mut outcomes = BTreeMap::new();
        for o in Outcome::ALL {
            let n = self
                .episodes
                .iter()
                .filter(|e| e.meta.outcome == *o)
                .count() as u64;
            if n > 0 {
                outcomes.insert(o.as_str().to_string(), n);
            }
        }
        Ok(WrittenDataset {
            dir: self.root.clone(),
            episodes: totals.episodes,
            frames: totals.frames,
            data_files: totals.data_files,
            tasks: self.tasks.len() as u64,
            simulated_hours: totals.simulated_hours,
            outcomes,
            resumed_from: self.resumed_from,
        })
    }
}
