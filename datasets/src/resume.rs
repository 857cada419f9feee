//! Reopening a dataset directory: what is there, whether it is this dataset, and what of it is complete.
//!
//! A data file counts once its episode metadata file (same chunk and file number) exists: the writer renames the
//! data file first and the metadata file second, so a crash between them leaves a data file without metadata,
//! which is removed and rewritten. Temporary files are removed. Everything else (totals, tasks, statistics, the
//! card's data) is rebuilt from the completed files, so a missing or stale `meta/info.json`, `stats.json` or
//! `tasks.parquet` does not matter.

use crate::episodes::{read_episodes, EpisodeMetaRow};
use crate::error::DatasetError;
use crate::frames::{columns, FrameColumns};
use crate::layout::{scan, FileId, Scan, INFO};
use crate::meta::{checksum, differences, read_info, InfoIn, Layout, FORMAT};
use crate::parquet_read::{read_footer, read_table};
use crate::plot::CardData;
use crate::spec::DatasetSpec;
use crate::stats::Stats;
use std::path::Path;

/// Footer keys of every data and episode metadata file.
pub const KEY_SPEC: &str = "vertibench.spec";
pub const KEY_LAYOUT: &str = "vertibench.layout";
pub const KEY_COMMAND: &str = "vertibench.command";

/// The completed part of a dataset.
pub struct Existing {
    pub command: Option<String>,
    pub episodes: Vec<EpisodeMetaRow>,
    pub files: u64,
    pub tasks: Vec<String>,
    pub stats: Stats,
    pub card: CardData,
    pub checksums: std::collections::BTreeMap<String, String>,
    /// `info.json` says the run finished.
    pub complete: bool,
}

fn footer_identity(
    path: &Path,
    kv: &std::collections::BTreeMap<String, String>,
) -> Result<(DatasetSpec, Layout), DatasetError> {
    let get = |k: &str| {
        kv.get(k).ok_or_else(|| {
            DatasetError::parquet(
                path,
                format!("no `{k}` in the footer: not written by this writer"),
            )
        })
    };
    let spec = serde_json::from_str(get(KEY_SPEC)?)
        .map_err(|e| DatasetError::parquet(path, format!("footer `{KEY_SPEC}`: {e}")))?;
    let layout = serde_json::from_str(get(KEY_LAYOUT)?)
        .map_err(|e| DatasetError::parquet(path, format!("footer `{KEY_LAYOUT}`: {e}")))?;
    Ok((spec, layout))
}

fn check_identity(
    root: &Path,
    there: (&DatasetSpec, &Layout),
    here: (&DatasetSpec, &Layout),
) -> Result<(), DatasetError> {
    let d = differences(there, here);
    if d.is_empty() {
        Ok(())
    } else {
        Err(DatasetError::OtherDataset {
            path: root.to_path_buf(),
            differences: d,
        })
    }
}

/// Loads what `root` holds of a dataset of `spec` and `layout`, cleaning what an interrupted run left; `None`
/// when nothing of it is complete yet.
pub fn load(
    root: &Path,
    spec: &DatasetSpec,
    layout: &Layout,
) -> Result<Option<Existing>, DatasetError> {
    let s = scan(root)?;
    if !s.unknown.is_empty() {
        return Err(DatasetError::NotADataset {
            path: root.to_path_buf(),
            entries: s.unknown,
        });
    }
    let info_path = root.join(INFO);
    let info = checked_info(root, &info_path, spec, layout)?;
    let mut command = info.as_ref().map(|i| i.vertibench.command.clone());
    if let Some(first) = s.episodes.first() {
        let path = root.join(first.episodes());
        let (_, kv) = read_footer(&path)?;
        let (fs, fl) = footer_identity(&path, &kv)?;
        check_identity(root, (&fs, &fl), (spec, layout))?;
        command = command.or_else(|| kv.get(KEY_COMMAND).cloned());
    }
    let chunks = layout.chunks_size;
    let (committed, orphan) = committed_files(root, &s, chunks)?;
    let mut out = Existing {
        command,
        episodes: Vec::new(),
        files: committed as u64,
        tasks: Vec::new(),
        stats: Stats::new(spec),
        card: CardData::default(),
        checksums: Default::default(),
        complete: info.as_ref().is_some_and(|i| i.vertibench.complete),
    };
    let mut frame = 0u64;
    for k in 0..committed as u64 {
        let id = FileId::nth(k, chunks);
        frame = load_file(root, spec, id, info.as_ref(), frame, &mut out)?;
    }
    if let Some(info) = &info {
        if info.total_episodes > out.episodes.len() as u64 {
            return Err(DatasetError::damaged(
                &info_path,
                format!(
                    "counts {} episodes but the data files hold {}: files are missing; restore them or remove the \
                     directory to start over",
                    info.total_episodes,
                    out.episodes.len()
                ),
            ));
        }
    }
    for t in &s.temps {
        std::fs::remove_file(t).map_err(|e| DatasetError::io(t, e))?;
    }
    if let Some(id) = orphan {
        let p = root.join(id.data());
        std::fs::remove_file(&p).map_err(|e| DatasetError::io(&p, e))?;
    }
    if info.is_none() && committed == 0 {
        return Ok(None);
    }
    Ok(Some(out))
}

/// `meta/info.json`, if there is one: of this writer's format and of the same dataset (spec and layout).
fn checked_info(
    root: &Path,
    info_path: &Path,
    spec: &DatasetSpec,
    layout: &Layout,
) -> Result<Option<InfoIn>, DatasetError> {
    if !info_path.is_file() {
        return Ok(None);
    }
    let info = read_info(info_path).map_err(|e| match e {
        DatasetError::Json { path, message } => DatasetError::Json {
            path,
            message: format!("{message} (remove it to rebuild it from the completed files)"),
        },
        e => e,
    })?;
    if info.vertibench.format != FORMAT {
        return Err(DatasetError::json(
            info_path,
            format!(
                "field `vertibench.format`: `{}`, this writer writes `{FORMAT}`",
                info.vertibench.format
            ),
        ));
    }
    check_identity(
        root,
        (&info.vertibench.spec, &info.vertibench.layout),
        (spec, layout),
    )?;
    Ok(Some(info))
}

/// How many files are complete (each data file with its metadata, numbered without gaps), and the data file of an
/// interrupted write beyond them, if any: at most the next data file, without its metadata (a crash between the two
/// renames); anything else is a gap no crash makes.
fn committed_files(
    root: &Path,
    s: &Scan,
    chunks: u64,
) -> Result<(usize, Option<FileId>), DatasetError> {
    let committed = (0..)
        .take_while(|&k| {
            let id = FileId::nth(k as u64, chunks);
            s.data.get(k) == Some(&id) && s.episodes.get(k) == Some(&id)
        })
        .count();
    let next = FileId::nth(committed as u64, chunks);
    let mut orphan = None;
    for id in s.data.iter().skip(committed) {
        if *id == next && orphan.is_none() && !s.episodes.contains(id) {
            orphan = Some(*id);
        } else {
            return Err(gap(root, &id.data(), committed, chunks));
        }
    }
    if let Some(id) = s.episodes.get(committed) {
        return Err(gap(root, &id.episodes(), committed, chunks));
    }
    Ok((committed, orphan))
}

/// Reads complete file `id` into `out`: its checksums against `info`'s, its episodes continuing the dataset from
/// frame `frame`, its frames matching them; the frame after its last.
fn load_file(
    root: &Path,
    spec: &DatasetSpec,
    id: FileId,
    info: Option<&InfoIn>,
    mut frame: u64,
    out: &mut Existing,
) -> Result<u64, DatasetError> {
    let epath = root.join(id.episodes());
    let rows = read_episodes(&epath, spec)?;
    for rel in [id.data(), id.episodes()] {
        let p = root.join(&rel);
        let bytes = std::fs::read(&p).map_err(|e| DatasetError::io(&p, e))?;
        let sum = checksum(&bytes);
        let recorded = info.and_then(|i| i.vertibench.checksums.get(&rel));
        if recorded.is_some_and(|r| *r != sum) {
            return Err(DatasetError::damaged(
                &p,
                "its bytes do not match its checksum in meta/info.json: restore it or remove the directory \
                 to start over",
            ));
        }
        out.checksums.insert(rel, sum);
    }
    for r in &rows {
        let want = out.episodes.len() as u64;
        if r.index != want
            || r.from != frame
            || r.to != r.from + r.length
            || r.file != id
            || r.length == 0
        {
            return Err(DatasetError::damaged(
                &epath,
                format!(
                    "episode row {} does not continue the dataset (expected episode {want} from frame {frame} \
                     in {}); remove the directory to start over",
                    r.index,
                    id.data()
                ),
            ));
        }
        frame = r.to;
        if !out.tasks.contains(&r.task) {
            out.tasks.push(r.task.clone());
        }
        out.episodes.push(r.clone());
    }
    let dpath = root.join(id.data());
    let table = read_table(&dpath, &columns(spec))?;
    let frames =
        FrameColumns::from_table(spec, table).map_err(|m| DatasetError::parquet(&dpath, m))?;
    let ranges = frames.episode_ranges();
    let fits = ranges.len() == rows.len()
        && ranges
            .iter()
            .zip(&rows)
            .all(|((e, r), row)| *e as u64 == row.index && r.len() as u64 == row.length);
    if !fits {
        return Err(DatasetError::damaged(
            &dpath,
            format!(
                "its frames do not match the episodes in {}; remove the directory to start over",
                id.episodes()
            ),
        ));
    }
    out.stats.add(&frames);
    out.card.add(&frames, &rows);

    Ok(frame)
}

fn gap(root: &Path, rel: &str, committed: usize, chunks: u64) -> DatasetError {
    let missing = FileId::nth(committed as u64, chunks);
    DatasetError::damaged(
        root.join(rel),
        format!(
            "present, but {} or {} before it is missing: restore it or remove the directory to start over",
            missing.data(),
            missing.episodes()
        ),
    )
}
