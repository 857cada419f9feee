//! `vb dataset validate` and `vb dataset info`: check a dataset directory against its `meta/info.json` and the
//! format (`FORMAT.md`), naming each problem with its file and field, and summarise a dataset.
//!
//! Checked: every data file's schema (column names, types, list shapes); counts (`total_*`, episode lengths and
//! `dataset_from_index`/`dataset_to_index`); continuity (`index` 0..N, `frame_index` from 0 in every episode,
//! `episode_index` contiguous, episodes in the data file their metadata names); `timestamp = frame_index / fps`;
//! `task_index` against `meta/tasks.parquet`; `next.done` and `next.reward` against their parts; `meta/stats.json`
//! against a recomputation; and completeness (the finished marker, no temporary files, the card). Damaged input
//! (truncated files, garbage JSON) is a problem in the report, never a panic.

use crate::checks::{check_checksum, check_frames, check_info, check_stats, Checker};
use crate::episodes::{read_episodes, read_tasks, EpisodeMetaRow};
use crate::error::DatasetError;
use crate::frames::{columns, FrameColumns};
use crate::layout::{scan, FileId, Scan, CARD, INFO, STATS, TASKS};
use crate::meta::{read_info, InfoIn};
use crate::parquet_read::read_table;
use crate::resume::{KEY_LAYOUT, KEY_SPEC};
use crate::spec::DatasetSpec;
use crate::stats::Stats;
use std::fmt;
use std::path::{Path, PathBuf};

/// One thing wrong with a dataset.
#[derive(Clone, Debug, PartialEq)]
pub struct Problem {
    /// The file, relative to the dataset's directory.
    pub file: String,
    /// The column or JSON field, when the problem is about one.
    pub field: Option<String>,
    pub message: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.field {
            Some(field) => write!(f, "{}: `{field}`: {}", self.file, self.message),
            None => write!(f, "{}: {}", self.file, self.message),
        }
    }
}

/// What `validate` found.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub dir: PathBuf,
    /// The run that wrote it finished (`vertibench.complete`), and nothing of an interrupted write is left.
    pub complete: bool,
    pub episodes: u64,
    pub frames: u64,
    pub data_files: u64,
    pub problems: Vec<Problem>,
}

impl Report {
    /// Complete and without problems.
    pub fn is_ok(&self) -> bool {
        self.complete && self.problems.is_empty()
    }
}

impl fmt::Display for Report {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let state = match (self.complete, self.problems.is_empty()) {
            (true, true) => "valid",
            (false, true) => "incomplete",
            _ => "invalid",
        };
        writeln!(
            f,
            "{}: {state} ({} episodes, {} frames, {} data files)",
            self.dir.display(),
            self.episodes,
            self.frames,
            self.data_files
        )?;
        for p in &self.problems {
            writeln!(f, "  {p}")?;
        }
        Ok(())
    }
}

/// Checks a dataset directory; `Err` only when the directory itself cannot be read.
pub fn validate(dir: &Path) -> Result<Report, DatasetError> {
    if !dir.is_dir() {
        return Err(DatasetError::io(
            dir,
            std::io::Error::new(std::io::ErrorKind::NotFound, "no such directory"),
        ));
    }
    let s = scan(dir)?;
    let mut c = Checker {
        problems: Vec::new(),
    };
    stray_files(&mut c, dir, &s);
    let info = match read_info(&dir.join(INFO)) {
        Ok(i) => Some(i),
        Err(e) => {
            c.error(INFO, &e);
            None
        }
    };
    let identity = match &info {
        Some(i) => Some((i.vertibench.spec.clone(), i.chunks_size)),
        None => footer_identity(dir, &s),
    };
    let Some((spec, chunks)) = identity else {
        c.add(
            INFO,
            None,
            "no spec: neither meta/info.json nor any data file says what the dataset is",
        );
        return Ok(report(dir, false, 0, 0, 0, c));
    };
    if let Some(i) = &info {
        check_info(&mut c, i, &spec);
    }
    let tasks = read_tasks(&dir.join(TASKS))
        .map_err(|e| c.error(TASKS, &e))
        .ok();
    let n = s.data.len().max(s.episodes.len());
    let mut stats = Stats::new(&spec);
    let mut stats_ok = true;
    let (mut episodes, mut frames) = (0u64, 0u64);
    for k in 0..n as u64 {
        let id = FileId::nth(k, chunks);
        let (drel, erel) = (id.data(), id.episodes());
        let has = (s.data.contains(&id), s.episodes.contains(&id));
        missing(&mut c, has, &drel, &erel);
        let rows = if has.1 {
            read_rows(&mut c, dir, &erel, &spec)
        } else {
            Vec::new()
        };
        check_rows(&mut c, &erel, &drel, id, &rows);
        for (rel, present) in [(&drel, has.0), (&erel, has.1)] {
            if present {
                check_checksum(&mut c, dir, rel, info.as_ref());
            }
        }
        let read = if has.0 {
            read_frames(&mut c, dir, &drel, &spec)
        } else {
            None
        };
        match read {
            Some(f) => {
                let fps = spec.control_rate_hz;
                let next = (episodes, frames);
                check_frames(&mut c, &drel, &f, &rows, next, fps, tasks.as_deref());
                stats.add(&f);
                frames += f.rows as u64;
                episodes += f.episode_ranges().len() as u64;
            }
            None => {
                // Go on from what the metadata says, so later files are not all reported out of place.
                stats_ok = false;
                frames += rows.iter().map(|r| r.length).sum::<u64>();
                episodes += rows.len() as u64;
            }
        }
    }
    if let Some(i) = &info {
        check_totals(&mut c, i, episodes, frames, tasks.as_deref());
    }
    check_stats(&mut c, dir, &stats, stats_ok);
    for rel in [TASKS, STATS] {
        if dir.join(rel).is_file() {
            check_checksum(&mut c, dir, rel, info.as_ref());
        }
    }
    let finished = check_finished(&mut c, dir, info.as_ref());
    let complete = finished && s.temps.is_empty();
    Ok(report(dir, complete, episodes, frames, n as u64, c))
}

/// Files that are no part of a dataset, and temporary files an interrupted write left.
fn stray_files(c: &mut Checker, dir: &Path, s: &Scan) {
    for u in &s.unknown {
        c.add(u, None, "not part of a dataset");
    }
    for t in &s.temps {
        let rel = t.strip_prefix(dir).unwrap_or(t).display().to_string();
        c.add(
            &rel,
            None,
            "temporary file left by an interrupted write: resume the run",
        );
    }
}

/// Whether the run that wrote the dataset finished (a problem if not), and its card when it did.
fn check_finished(c: &mut Checker, dir: &Path, info: Option<&InfoIn>) -> bool {
    let finished = info.is_some_and(|i| i.vertibench.complete);
    if info.is_some() && !finished {
        c.add(
            INFO,
            Some("vertibench.complete"),
            "false: the run writing this dataset has not finished (or was interrupted): resume it",
        );
    }
    if finished && !dir.join(CARD).is_file() {
        c.add(CARD, None, "missing: the dataset card");
    }
    finished
}

/// Data file `drel` or its metadata `erel` missing (`has`: whether each is there).
fn missing(c: &mut Checker, has: (bool, bool), drel: &str, erel: &str) {
    if !has.0 {
        c.add(drel, None, "missing (the files are numbered without gaps)");
    }
    if !has.1 {
        let msg = format!("missing: the metadata of the episodes in {drel}");
        c.add(erel, None, msg);
    }
}

/// The episode metadata in `erel` (none if it cannot be read: a problem then).
fn read_rows(c: &mut Checker, dir: &Path, erel: &str, spec: &DatasetSpec) -> Vec<EpisodeMetaRow> {
    read_episodes(&dir.join(erel), spec).unwrap_or_else(|e| {
        c.error(erel, &e);
        Vec::new()
    })
}

/// The episode metadata of data file `drel` (`erel`): finite final values, the file each names, its index range.
fn check_rows(c: &mut Checker, erel: &str, drel: &str, id: FileId, rows: &[EpisodeMetaRow]) {
    for r in rows {
        for (field, v) in [
            ("final_state", &r.meta.final_state[..]),
            ("final_goal", &r.meta.final_goal[..]),
        ] {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                c.add(
                    erel,
                    Some(field),
                    format!(
                        "episode {}: value {i} is {} (values must be finite)",
                        r.index, v[i]
                    ),
                );
            }
        }
        if r.file != id {
            c.add(
                erel,
                Some("data/file_index"),
                format!("episode {} names {}, not {drel}", r.index, r.file.data()),
            );
        }
        if r.to != r.from + r.length {
            c.add(
                erel,
                Some("dataset_to_index"),
                format!(
                    "episode {}: from {} + length {} != {}",
                    r.index, r.from, r.length, r.to
                ),
            );
        }
    }
}

/// `meta/info.json`'s totals and split against what the files hold.
fn check_totals(c: &mut Checker, i: &InfoIn, episodes: u64, frames: u64, tasks: Option<&[String]>) {
    for (field, there, here) in [
        ("total_frames", i.total_frames, frames),
        ("total_episodes", i.total_episodes, episodes),
        (
            "total_tasks",
            i.total_tasks,
            tasks.map_or(i.total_tasks, |t| t.len() as u64),
        ),
    ] {
        if there != here {
            c.add(INFO, Some(field), format!("{there}, the files hold {here}"));
        }
    }
    if i.splits.get("train") != Some(&format!("0:{episodes}")) {
        c.add(
            INFO,
            Some("splits"),
            format!("expected {{\"train\": \"0:{episodes}\"}}"),
        );
    }
}

fn report(
    dir: &Path,
    complete: bool,
    episodes: u64,
    frames: u64,
    data_files: u64,
    c: Checker,
) -> Report {
    Report {
        dir: dir.to_path_buf(),
        complete,
        episodes,
        frames,
        data_files,
        problems: c.problems,
    }
}

/// Reads a data file's frames, reporting why it cannot be read.
fn read_frames(c: &mut Checker, dir: &Path, rel: &str, spec: &DatasetSpec) -> Option<FrameColumns> {
    let table = match read_table(&dir.join(rel), &columns(spec)) {
        Ok(t) => t,
        Err(e) => {
            c.error(rel, &e);
            return None;
        }
    };
    let footer = table
        .metadata
        .get(KEY_SPEC)
        .and_then(|j| serde_json::from_str::<DatasetSpec>(j).ok());
    if footer.as_ref() != Some(spec) {
        c.add(
            rel,
            Some(KEY_SPEC),
            "the footer's spec is not meta/info.json's",
        );
    }
    match FrameColumns::from_table(spec, table) {
        Ok(f) => Some(f),
        Err(m) => {
            c.add(rel, None, m);
            None
        }
    }
}

/// The spec and files per chunk in the footer of the first data or episode file (when `info.json` is unusable).
fn footer_identity(dir: &Path, s: &crate::layout::Scan) -> Option<(DatasetSpec, u64)> {
    let first = s
        .episodes
        .first()
        .map(|id| id.episodes())
        .or_else(|| s.data.first().map(|id| id.data()))?;
    let (_, kv) = crate::parquet_read::read_footer(&dir.join(first)).ok()?;
    let spec = serde_json::from_str(kv.get(KEY_SPEC)?).ok()?;
    let layout: crate::meta::Layout = serde_json::from_str(kv.get(KEY_LAYOUT)?).ok()?;
    Some((spec, layout.chunks_size))
}
