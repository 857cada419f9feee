//! Per-episode metadata (`meta/episodes/chunk-NNN/file-NNN.parquet`, one file per data file, one row per
//! episode) and the task table (`meta/tasks.parquet`).

use crate::error::DatasetError;
use crate::layout::FileId;
use crate::parquet_io::{write_table, Data, Kind};
use crate::parquet_read::read_table;
use crate::record::{DatasetKind, EpisodeMeta, FailureClass, FailureWindow};
use crate::spec::DatasetSpec;
use contracts::{ElevationLevel, EndReason, ObstacleDensity, Outcome, SemanticsKind, TaskId};
use std::path::Path;

/// One episode as the metadata table holds it.
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeMetaRow {
    pub index: u64,
    pub meta: EpisodeMeta,
    pub length: u64,
    /// Its LeRobot task string ([`task_string`]).
    pub task: String,
    /// The data file (and episode metadata file) holding it.
    pub file: FileId,
    /// Its frames' global indices, `from..to`.
    pub from: u64,
    pub to: u64,
}

/// The LeRobot task string of an episode: what was asked of the vehicle.
pub fn task_string(meta: &EpisodeMeta) -> String {
    match meta.kind {
        DatasetKind::Expert => "drive to the goal".into(),
        DatasetKind::Random => match (meta.policy.as_str(), meta.policy_params.get("speed")) {
            ("sinusoid", Some(v)) => format!("random exploration: sinusoidal steering at {v} m/s"),
            ("sinusoid", None) => "random exploration: sinusoidal steering".into(),
            (p, _) => format!("random exploration: {p}"),
        },
        DatasetKind::Failures => match meta.failure.as_ref().map(|f| f.class) {
            Some(FailureClass::Rollover) => "failure: rollover".into(),
            Some(FailureClass::Stuck) => "failure: stuck".into(),
            None => format!("failure: {}", meta.outcome),
        },
    }
}

/// The columns of an episode metadata file, in order.
pub fn columns() -> Vec<(String, Kind)> {
    use Kind::*;
    [
        ("episode_index", I64),
        ("tasks", ListStr),
        ("length", I64),
        ("data/chunk_index", I64),
        ("data/file_index", I64),
        ("dataset_from_index", I64),
        ("dataset_to_index", I64),
        ("meta/episodes/chunk_index", I64),
        ("meta/episodes/file_index", I64),
        ("task_id", OptStr),
        ("world_id", I64),
        ("level", Str),
        ("semantics", Str),
        ("density", Str),
        ("start_ground", Str),
        ("start_x", F64),
        ("start_y", F64),
        ("start_yaw", F64),
        ("goal_x", F64),
        ("goal_y", F64),
        ("policy", Str),
        ("policy_params", Str),
        ("seed", U64),
        ("outcome", Str),
        ("reason", Str),
        ("failure_class", OptStr),
        ("failure_source", OptStr),
        ("failure_source_episode", OptU64),
        ("failure_start_time", OptF64),
        ("failure_short", OptBool),
        ("final_state", ListF64(vec![15])),
        ("final_goal", ListF64(vec![3])),
        ("vehicle", Str),
        ("scale", F64),
        ("sim_version", Str),
        ("task_set_version", Str),
    ]
    .into_iter()
    .map(|(n, k)| (n.to_string(), k))
    .collect()
}

fn enum_str<T: serde::Serialize>(v: &T) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        _ => String::new(),
    }
}

/// The bytes of an episode metadata file.
pub fn write_episodes(
    path: &Path,
    spec: &DatasetSpec,
    rows: &[EpisodeMetaRow],
    metadata: &[(String, String)],
) -> Result<Vec<u8>, DatasetError> {
    let i64s = |f: &dyn Fn(&EpisodeMetaRow) -> i64| Data::I64(rows.iter().map(f).collect());
    let f64s = |f: &dyn Fn(&EpisodeMetaRow) -> f64| Data::F64(rows.iter().map(f).collect());
    let strs = |f: &dyn Fn(&EpisodeMetaRow) -> String| Data::Str(rows.iter().map(f).collect());
    let fail = |r: &EpisodeMetaRow| r.meta.failure.clone();
    let mut params = Vec::with_capacity(rows.len());
    for r in rows {
        params.push(
            serde_json::to_string(&r.meta.policy_params)
                .map_err(|e| DatasetError::record(r.index, "policy_params", e))?,
        );
    }
    let data = vec![
        i64s(&|r| r.index as i64),
        Data::ListStr(rows.iter().map(|r| vec![r.task.clone()]).collect()),
        i64s(&|r| r.length as i64),
        i64s(&|r| r.file.chunk as i64),
        i64s(&|r| r.file.file as i64),
        i64s(&|r| r.from as i64),
        i64s(&|r| r.to as i64),
        i64s(&|r| r.file.chunk as i64),
        i64s(&|r| r.file.file as i64),
        Data::OptStr(
            rows.iter()
                .map(|r| r.meta.task_id.map(|t| t.to_string()))
                .collect(),
        ),
        i64s(&|r| i64::from(r.meta.world_id)),
        strs(&|r| r.meta.level.to_string()),
        strs(&|r| r.meta.semantics.to_string()),
        strs(&|r| r.meta.density.to_string()),
        strs(&|r| r.meta.start_ground.clone()),
        f64s(&|r| r.meta.start[0]),
        f64s(&|r| r.meta.start[1]),
        f64s(&|r| r.meta.start[2]),
        f64s(&|r| r.meta.goal[0]),
        f64s(&|r| r.meta.goal[1]),
        strs(&|r| r.meta.policy.clone()),
        Data::Str(params),
        Data::U64(rows.iter().map(|r| r.meta.seed).collect()),
        strs(&|r| r.meta.outcome.to_string()),
        strs(&|r| r.meta.reason.to_string()),
        Data::OptStr(
            rows.iter()
                .map(|r| fail(r).map(|f| enum_str(&f.class)))
                .collect(),
        ),
        Data::OptStr(rows.iter().map(|r| fail(r).map(|f| f.source)).collect()),
        Data::OptU64(
            rows.iter()
                .map(|r| fail(r).map(|f| f.source_episode))
                .collect(),
        ),
        Data::OptF64(rows.iter().map(|r| fail(r).map(|f| f.start_time)).collect()),
        Data::OptBool(rows.iter().map(|r| fail(r).map(|f| f.short)).collect()),
        Data::ListF64(rows.iter().flat_map(|r| r.meta.final_state).collect()),
        Data::ListF64(rows.iter().flat_map(|r| r.meta.final_goal).collect()),
        strs(&|_| spec.vehicle.to_string()),
        f64s(&|_| spec.scale),
        strs(&|_| spec.sim_version.to_string()),
        strs(&|_| spec.task_set_version.clone()),
    ];
    let cols = columns()
        .into_iter()
        .zip(data)
        .map(|((n, k), d)| (n, k, d))
        .collect();
    write_table(path, cols, metadata)
}

/// Typed access to the columns of a read table, by position in [`columns`].
struct Cols(Vec<Data>);

impl Cols {
    fn i64(&self, i: usize, row: usize) -> i64 {
        match &self.0[i] {
            Data::I64(v) => v.get(row).copied().unwrap_or_default(),
            _ => 0,
        }
    }
    fn f64(&self, i: usize, row: usize) -> f64 {
        match &self.0[i] {
            Data::F64(v) => v.get(row).copied().unwrap_or_default(),
            _ => 0.0,
        }
    }
    /// Row `row` of a fixed-shape float64 column of `N` values a row (zeros when absent).
    fn f64s<const N: usize>(&self, i: usize, row: usize) -> [f64; N] {
        match &self.0[i] {
            Data::ListF64(v) => v
                .get(row * N..(row + 1) * N)
                .and_then(|s| <[f64; N]>::try_from(s).ok())
                .unwrap_or([0.0; N]),
            _ => [0.0; N],
        }
    }
    fn str(&self, i: usize, row: usize) -> &str {
        match &self.0[i] {
            Data::Str(v) => v.get(row).map_or("", String::as_str),
            _ => "",
        }
    }
    fn opt_str(&self, i: usize, row: usize) -> Option<&str> {
        match &self.0[i] {
            Data::OptStr(v) => v.get(row).and_then(|s| s.as_deref()),
            _ => None,
        }
    }
}

fn parse<T>(
    path: &Path,
    row: usize,
    field: &str,
    r: Result<T, impl std::fmt::Display>,
) -> Result<T, DatasetError> {
    r.map_err(|e| DatasetError::parquet(path, format!("row {row}, column `{field}`: {e}")))
}

fn unsigned(path: &Path, row: usize, field: &str, v: i64) -> Result<u64, DatasetError> {
    parse(
        path,
        row,
        field,
        u64::try_from(v).map_err(|_| format!("{v} is negative")),
    )
}

/// Reads an episode metadata file written for `spec`.
pub fn read_episodes(path: &Path, spec: &DatasetSpec) -> Result<Vec<EpisodeMetaRow>, DatasetError> {
    let table = read_table(path, &columns())?;
    let (rows, c) = (table.rows, Cols(table.columns));
    let mut out = Vec::with_capacity(rows);
    for r in 0..rows {
        let tasks = match &c.0[1] {
            Data::ListStr(v) => v.get(r).cloned().unwrap_or_default(),
            _ => Vec::new(),
        };
        let [task] = <[String; 1]>::try_from(tasks).map_err(|t| {
            DatasetError::parquet(
                path,
                format!("row {r}, column `tasks`: {} tasks, expected 1", t.len()),
            )
        })?;
        let failure = match c.opt_str(25, r) {
            None => None,
            Some(class) => Some(FailureWindow {
                class: parse(
                    path,
                    r,
                    "failure_class",
                    serde_json::from_value::<FailureClass>(class.into()),
                )?,
                source: c.opt_str(26, r).unwrap_or_default().to_string(),
                source_episode: match &c.0[27] {
                    Data::OptU64(v) => v.get(r).copied().flatten().unwrap_or_default(),
                    _ => 0,
                },
                start_time: match &c.0[28] {
                    Data::OptF64(v) => v.get(r).copied().flatten().unwrap_or_default(),
                    _ => 0.0,
                },
                short: match &c.0[29] {
                    Data::OptBool(v) => v.get(r).copied().flatten().unwrap_or_default(),
                    _ => false,
                },
            }),
        };
        let meta = EpisodeMeta {
            kind: spec.kind,
            task_id: c
                .opt_str(9, r)
                .map(|s| parse(path, r, "task_id", s.parse::<TaskId>()))
                .transpose()?,
            world_id: parse(path, r, "world_id", u32::try_from(c.i64(10, r)))?,
            level: parse(path, r, "level", ElevationLevel::parse(c.str(11, r)))?,
            semantics: parse(path, r, "semantics", SemanticsKind::parse(c.str(12, r)))?,
            density: parse(path, r, "density", ObstacleDensity::parse(c.str(13, r)))?,
            start_ground: c.str(14, r).to_string(),
            start: [c.f64(15, r), c.f64(16, r), c.f64(17, r)],
            goal: [c.f64(18, r), c.f64(19, r)],
            policy: c.str(20, r).to_string(),
            policy_params: parse(path, r, "policy_params", serde_json::from_str(c.str(21, r)))?,
            seed: match &c.0[22] {
                Data::U64(v) => v.get(r).copied().unwrap_or_default(),
                _ => 0,
            },
            outcome: parse(path, r, "outcome", Outcome::parse(c.str(23, r)))?,
            reason: parse(path, r, "reason", EndReason::parse(c.str(24, r)))?,
            failure,
            final_state: c.f64s(30, r),
            final_goal: c.f64s(31, r),
        };
        let file = FileId {
            chunk: unsigned(path, r, "data/chunk_index", c.i64(3, r))?,
            file: unsigned(path, r, "data/file_index", c.i64(4, r))?,
        };
        out.push(EpisodeMetaRow {
            index: unsigned(path, r, "episode_index", c.i64(0, r))?,
            meta,
            length: unsigned(path, r, "length", c.i64(2, r))?,
            task,
            file,
            from: unsigned(path, r, "dataset_from_index", c.i64(5, r))?,
            to: unsigned(path, r, "dataset_to_index", c.i64(6, r))?,
        });
    }
    Ok(out)
}

/// pandas' metadata making `task` the index (LeRobot reads the table with `pd.read_parquet` and looks tasks up by
/// index).
fn pandas_metadata() -> String {
    serde_json::json!({
        "index_columns": ["task"],
        "column_indexes": [],
        "columns": [
            {"name": "task_index", "field_name": "task_index", "pandas_type": "int64", "numpy_type": "int64", "metadata": null},
            {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object", "metadata": null}
        ],
        "creator": {"library": "vertibench", "version": env!("CARGO_PKG_VERSION")},
        "pandas_version": "2.2.0"
    })
    .to_string()
}

pub fn task_columns() -> Vec<(String, Kind)> {
    vec![("task_index".into(), Kind::I64), ("task".into(), Kind::Str)]
}

/// The bytes of `meta/tasks.parquet`: `task_index`, `task`.
pub fn write_tasks(path: &Path, tasks: &[String]) -> Result<Vec<u8>, DatasetError> {
    let cols = task_columns()
        .into_iter()
        .zip([
            Data::I64((0..tasks.len() as i64).collect()),
            Data::Str(tasks.to_vec()),
        ])
        .map(|((n, k), d)| (n, k, d))
        .collect();
    write_table(path, cols, &[("pandas".to_string(), pandas_metadata())])
}

/// Reads `meta/tasks.parquet`: the task strings in `task_index` order, checking the indices are `0..n`.
pub fn read_tasks(path: &Path) -> Result<Vec<String>, DatasetError> {
    let table = read_table(path, &task_columns())?;
    match <[Data; 2]>::try_from(table.columns) {
        Ok([Data::I64(idx), Data::Str(tasks)]) => {
            if let Some(r) = idx.iter().enumerate().position(|(i, &t)| t != i as i64) {
                return Err(DatasetError::parquet(
                    path,
                    format!("row {r}: task_index {}, expected {r}", idx[r]),
                ));
            }
            Ok(tasks)
        }
        _ => Err(DatasetError::parquet(path, "unexpected columns")),
    }
}
