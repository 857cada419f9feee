//! Where a dataset's files live (LeRobot v3's templates), atomic writes (a temporary name in the same directory,
//! renamed when complete) and the scan of a directory that resume and `validate` share.

use crate::error::DatasetError;
use std::io::Write;
use std::path::{Path, PathBuf};

pub const INFO: &str = "meta/info.json";
pub const STATS: &str = "meta/stats.json";
pub const TASKS: &str = "meta/tasks.parquet";
pub const CARD: &str = "README.md";
/// The card's pictures.
pub const CARD_DIR: &str = "card";
/// LeRobot's data path template (`meta/info.json`'s `data_path`).
pub const DATA_PATH_TEMPLATE: &str = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
/// Files being written are `.<name>.tmp`: hidden, so readers that list a directory (pyarrow's datasets skip names
/// starting with `.` or `_`) or glob `*.parquet` (LeRobot, the card's `data/*/*.parquet`) never see them.
pub const TMP_SUFFIX: &str = ".tmp";

/// Whether a file name is one of the writer's temporary files.
pub fn is_temp(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(TMP_SUFFIX)
}

/// A data file's (and its episode metadata file's) place: `chunk-{chunk}/file-{file}`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct FileId {
    pub chunk: u64,
    pub file: u64,
}

impl FileId {
    /// The `seq`th file of a dataset (0-based) with `chunks_size` files per chunk directory.
    pub fn nth(seq: u64, chunks_size: u64) -> FileId {
        let per = chunks_size.max(1);
        FileId {
            chunk: seq / per,
            file: seq % per,
        }
    }
    pub fn seq(self, chunks_size: u64) -> u64 {
        self.chunk * chunks_size.max(1) + self.file
    }
    /// `data/chunk-NNN/file-NNN.parquet`.
    pub fn data(self) -> String {
        format!("data/chunk-{:03}/file-{:03}.parquet", self.chunk, self.file)
    }
    /// `meta/episodes/chunk-NNN/file-NNN.parquet`: the metadata of the episodes in [`Self::data`].
    pub fn episodes(self) -> String {
        format!(
            "meta/episodes/chunk-{:03}/file-{:03}.parquet",
            self.chunk, self.file
        )
    }
}

/// `dir/.name.tmp` for `dir/name` (same directory, so the rename is atomic).
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut name = std::ffi::OsString::from(".");
    name.push(path.file_name().unwrap_or_default());
    name.push(TMP_SUFFIX);
    path.with_file_name(name)
}

/// Writes `bytes` to `path` through a temporary file in the same directory, synced, then renamed: a reader sees
/// the old file or the whole new one, never part of it. Creates missing parent directories.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), DatasetError> {
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| DatasetError::io(parent, e))?;
    }
    let tmp = tmp_path(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    })();
    if let Err(e) = result {
        // Best effort: a full disk should not also be left holding the partial temporary file.
        let _ = std::fs::remove_file(&tmp);
        return Err(DatasetError::io(&tmp, e));
    }
    std::fs::rename(&tmp, path).map_err(|e| DatasetError::io(path, e))
}

/// What a directory holds, as far as a dataset is concerned.
#[derive(Clone, Debug, Default)]
pub struct Scan {
    /// Completed data files, in order.
    pub data: Vec<FileId>,
    /// Completed episode metadata files, in order.
    pub episodes: Vec<FileId>,
    /// Files left by an interrupted write.
    pub temps: Vec<PathBuf>,
    /// Entries that a dataset does not have (relative paths).
    pub unknown: Vec<String>,
    /// Whether any dataset file (meta, data, card) is there.
    pub any: bool,
}

fn entries(dir: &Path) -> Result<Vec<(String, bool)>, DatasetError> {
    let rd = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(DatasetError::io(dir, e)),
    };
    let mut out = Vec::new();
    for e in rd {
        let e = e.map_err(|e| DatasetError::io(dir, e))?;
        let is_dir = e
            .file_type()
            .map_err(|err| DatasetError::io(e.path(), err))?
            .is_dir();
        out.push((e.file_name().to_string_lossy().into_owned(), is_dir));
    }
    out.sort();
    Ok(out)
}

fn number(name: &str, prefix: &str, suffix: &str) -> Option<u64> {
    let digits = name.strip_prefix(prefix)?.strip_suffix(suffix)?;
    if digits.len() >= 3 && digits.bytes().all(|b| b.is_ascii_digit()) {
        digits.parse().ok()
    } else {
        None
    }
}

/// Scans `root/<base>/chunk-NNN/file-NNN.parquet` (base `data` or `meta/episodes`).
fn scan_chunks(
    root: &Path,
    base: &str,
    files: &mut Vec<FileId>,
    scan: &mut Scan,
) -> Result<(), DatasetError> {
    for (name, is_dir) in entries(&root.join(base))? {
        let rel = format!("{base}/{name}");
        match number(&name, "chunk-", "") {
            Some(chunk) if is_dir => {
                for (fname, fdir) in entries(&root.join(&rel))? {
                    let frel = format!("{rel}/{fname}");
                    if fdir {
                        scan.unknown.push(frel);
                    } else if let Some(file) = number(&fname, "file-", ".parquet") {
                        files.push(FileId { chunk, file });
                    } else if is_temp(&fname) {
                        scan.temps.push(root.join(frel));
                    } else if !fname.starts_with('.') {
                        scan.unknown.push(frel);
                    }
                }
            }
            _ if name.starts_with('.') => {}
            _ => scan.unknown.push(rel),
        }
    }
    files.sort();
    Ok(())
}

/// Lists what `root` holds: completed data and episode files, temporary files, and anything else (hidden entries,
/// such as a hub clone's `.gitattributes`, are ignored).
pub fn scan(root: &Path) -> Result<Scan, DatasetError> {
    let mut scan = Scan::default();
    for (name, is_dir) in entries(root)? {
        match (name.as_str(), is_dir) {
            ("data", true) => {
                let mut files = Vec::new();
                scan_chunks(root, "data", &mut files, &mut scan)?;
                scan.data = files;
                scan.any = true;
            }
            ("meta", true) => {
                scan.any = true;
                for (m, mdir) in entries(&root.join("meta"))? {
                    match (m.as_str(), mdir) {
                        ("episodes", true) => {
                            let mut files = Vec::new();
                            scan_chunks(root, "meta/episodes", &mut files, &mut scan)?;
                            scan.episodes = files;
                        }
                        ("info.json" | "stats.json" | "tasks.parquet", false) => {}
                        (m, false) if is_temp(m) => scan.temps.push(root.join("meta").join(m)),
                        (m, _) if m.starts_with('.') => {}
                        (m, _) => scan.unknown.push(format!("meta/{m}")),
                    }
                }
            }
            (CARD_DIR, true) => scan.any = true,
            (CARD, false) => scan.any = true,
            (n, false) if n == ".README.md.tmp" => scan.temps.push(root.join(n)),
            (n, _) if n.starts_with('.') => {}
            (n, _) => scan.unknown.push(n.to_string()),
        }
    }
    Ok(scan)
}
