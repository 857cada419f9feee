//! The checks `validate` runs on one file or field, collecting problems ([`Checker`]).

use crate::episodes::EpisodeMetaRow;
use crate::error::DatasetError;
use crate::frames::{timestamp, FrameColumns};
use crate::layout::{DATA_PATH_TEMPLATE, INFO, STATS, TASKS};
use crate::meta::{checksum, features, InfoIn, CODEBASE_VERSION, FORMAT};
use crate::spec::DatasetSpec;
use crate::stats::{first_difference, Stats};
use crate::validate::Problem;
use std::path::Path;

/// Problems reported per file and field before the rest are summarised.
pub(crate) const PER_FIELD: usize = 3;

pub(crate) struct Checker {
    pub(crate) problems: Vec<Problem>,
}

impl Checker {
    pub(crate) fn add(&mut self, file: &str, field: Option<&str>, message: impl Into<String>) {
        let same = self
            .problems
            .iter()
            .filter(|p| p.file == file && p.field.as_deref() == field)
            .count();
        if same < PER_FIELD {
            self.problems.push(Problem {
                file: file.to_string(),
                field: field.map(str::to_string),
                message: message.into(),
            });
        }
    }
    pub(crate) fn error(&mut self, file: &str, e: &DatasetError) {
        let text = e.to_string();
        // The error names the absolute path; the report names files relative to the dataset.
        let message = text
            .split_once(": ")
            .map_or(text.as_str(), |(_, m)| m)
            .to_string();
        self.add(file, None, message);
    }
}

/// Checks every frame of a data file whose episodes' metadata rows are `rows`.
pub(crate) fn check_frames(
    c: &mut Checker,
    rel: &str,
    f: &FrameColumns,
    rows: &[EpisodeMetaRow],
    next: (u64, u64),
    fps: f64,
    tasks: Option<&[String]>,
) {
    let (mut episode, mut index) = next;
    let ranges = f.episode_ranges();
    if ranges.len() != rows.len() {
        c.add(
            rel,
            Some("episode_index"),
            format!(
                "{} episodes in the frames, {} in the metadata",
                ranges.len(),
                rows.len()
            ),
        );
    }
    for (k, (e, range)) in ranges.iter().enumerate() {
        if *e as u64 != episode {
            c.add(
                rel,
                Some("episode_index"),
                format!("row {}: episode {e}, expected {episode}", range.start),
            );
        }
        if let Some(row) = rows.get(k) {
            if row.index != *e as u64 || row.length != range.len() as u64 || row.from != index {
                c.add(
                    rel,
                    Some("episode_index"),
                    format!(
                        "episode {e}: rows {}..{} at index {index}, its metadata says episode {} of length {} from {}",
                        range.start, range.end, row.index, row.length, row.from
                    ),
                );
            }
        }
        // The episode's task index, when both the task table and the episode's metadata could be read.
        let task = match (tasks, rows.get(k)) {
            (Some(ts), Some(row)) => Some(ts.iter().position(|t| *t == row.task)),
            _ => None,
        };
        for (j, r) in range.clone().enumerate() {
            check_frame(c, rel, f, r, (j, index), fps, task);
            index += 1;
        }
        episode = *e as u64 + 1;
    }
}

/// Row `r` of the data file: frame `j` of its episode and dataset frame `index`, whose task has `task`'s index
/// (`None`: not checked; `Some(None)`: not in the task table).
fn check_frame(
    c: &mut Checker,
    rel: &str,
    f: &FrameColumns,
    r: usize,
    (j, index): (usize, u64),
    fps: f64,
    task: Option<Option<usize>>,
) {
    if f.index[r] as u64 != index {
        c.add(
            rel,
            Some("index"),
            format!("row {r}: {}, expected {index}", f.index[r]),
        );
    }
    if f.frame_index[r] != j as i64 {
        c.add(
            rel,
            Some("frame_index"),
            format!("row {r}: {}, expected {j}", f.frame_index[r]),
        );
    }
    let t = timestamp(j as u64, fps);
    if (f.timestamp[r] - t).abs() > 1e-4 {
        c.add(
            rel,
            Some("timestamp"),
            format!(
                "row {r}: {}, expected frame_index / fps = {t}",
                f.timestamp[r]
            ),
        );
    }
    match task {
        None => {}
        Some(Some(t)) if f.task_index[r] == t as i64 => {}
        Some(_) => c.add(
            rel,
            Some("task_index"),
            format!(
                "row {r}: {}, not the index of the episode's task in {TASKS}",
                f.task_index[r]
            ),
        ),
    }
    if f.done[r] != (f.terminated[r] || f.truncated[r]) {
        c.add(
            rel,
            Some("next.done"),
            format!("row {r}: not next.terminated or next.truncated"),
        );
    }
    let terms = &f.reward_terms[4 * r..4 * r + 4];
    let sum = terms[0] + terms[1] + terms[2] + terms[3];
    if (f.reward[r] - sum).abs() > 1e-5 * sum.abs().max(1.0) {
        c.add(
            rel,
            Some("next.reward"),
            format!("row {r}: {}, its terms sum to {sum}", f.reward[r]),
        );
    }
}

pub(crate) fn check_info(c: &mut Checker, i: &InfoIn, spec: &DatasetSpec) {
    let mut field = |name: &str, ok: bool, message: String| {
        if !ok {
            c.add(INFO, Some(name), message);
        }
    };
    field(
        "codebase_version",
        i.codebase_version == CODEBASE_VERSION,
        format!("`{}`, expected `{CODEBASE_VERSION}`", i.codebase_version),
    );
    field(
        "vertibench.format",
        i.vertibench.format == FORMAT,
        format!("`{}`, expected `{FORMAT}`", i.vertibench.format),
    );
    field(
        "data_path",
        i.data_path == DATA_PATH_TEMPLATE,
        format!("`{}`, expected `{DATA_PATH_TEMPLATE}`", i.data_path),
    );
    field(
        "robot_type",
        i.robot_type == spec.vehicle,
        format!(
            "`{}`, the spec's vehicle is `{}`",
            i.robot_type, spec.vehicle
        ),
    );
    field(
        "fps",
        i.fps == spec.control_rate_hz,
        format!(
            "{}, the spec's control rate is {}",
            i.fps, spec.control_rate_hz
        ),
    );
    field(
        "chunks_size",
        i.chunks_size == i.vertibench.layout.chunks_size,
        format!(
            "{}, vertibench.layout says {}",
            i.chunks_size, i.vertibench.layout.chunks_size
        ),
    );
    let want = features(spec);
    for (name, f) in &want.0 {
        match i.features.get(name) {
            None => c.add(INFO, Some(&format!("features.{name}")), "missing"),
            Some(g) if g != f => c.add(
                INFO,
                Some(&format!("features.{name}")),
                format!("dtype {} shape {:?}, expected dtype {} shape {:?} (names as the format gives them)", g.dtype, g.shape, f.dtype, f.shape),
            ),
            Some(_) => {}
        }
    }
    for name in i.features.keys() {
        if !want.0.iter().any(|(n, _)| n == name) {
            c.add(
                INFO,
                Some(&format!("features.{name}")),
                "not a column of the data files",
            );
        }
    }
}

pub(crate) fn check_stats(c: &mut Checker, dir: &Path, stats: &Stats, recomputable: bool) {
    let path = dir.join(STATS);
    let recorded: serde_json::Value = match crate::json::read(&path) {
        Ok(v) => v,
        Err(e) => return c.error(STATS, &e),
    };
    if !recomputable {
        return;
    }
    let recomputed = stats
        .to_bytes(&path)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok());
    if let Some(d) = recomputed.and_then(|r| first_difference(&recorded, &r, "")) {
        c.add(STATS, None, format!("does not match the data: {d}"));
    }
}

/// A file's bytes against its checksum in `info.json` (a file without one is named only in a finished dataset:
/// a crash may leave completed files that `info.json` does not list yet).
pub(crate) fn check_checksum(c: &mut Checker, dir: &Path, rel: &str, info: Option<&InfoIn>) {
    let Some(info) = info else { return };
    let bytes = match std::fs::read(dir.join(rel)) {
        Ok(b) => b,
        Err(e) => return c.add(rel, None, e.to_string()),
    };
    match info.vertibench.checksums.get(rel) {
        Some(sum) if *sum == checksum(&bytes) => {}
        Some(_) => c.add(
            rel,
            None,
            format!(
                "its bytes do not match its checksum in {INFO}: the file was changed or damaged"
            ),
        ),
        None if info.vertibench.complete => c.add(rel, None, format!("no checksum in {INFO}")),
        None => {}
    }
}
