//! The per-frame table (`data/chunk-NNN/file-NNN.parquet`): its columns for a spec, a column buffer that episodes
//! are checked into, and the conversion to and from Parquet columns.

use crate::error::DatasetError;
use crate::parquet_io::{Data, Kind};
use crate::parquet_read::Table;
use crate::record::RecordedEpisode;
use crate::spec::{DatasetSpec, Variant};

/// Largest finite float16 value: crops beyond it cannot be stored.
const F16_MAX: f64 = 65504.0;

/// A spec's frame columns, in file order.
pub fn columns(spec: &DatasetSpec) -> Vec<(String, Kind)> {
    let list = |n: usize| Kind::ListF32(vec![n]);
    let mut c = vec![
        ("observation.state", Kind::ListF64(vec![15])),
        ("observation.goal", Kind::ListF64(vec![3])),
        ("observation.wheels", Kind::ListF32(vec![spec.wheels, 4])),
    ];
    if spec.variant == Variant::Full {
        let s = spec.crop.size;
        c.push(("observation.elevation", Kind::ListF16(vec![s, s])));
        c.push(("observation.semantics", Kind::ListF16(vec![s, s])));
    }
    c.extend([
        ("action", list(3)),
        ("next.reward", Kind::F32),
        ("next.reward_terms", list(4)),
        ("next.done", Kind::Bool),
        ("next.terminated", Kind::Bool),
        ("next.truncated", Kind::Bool),
        ("timestamp", Kind::F32),
        ("frame_index", Kind::I64),
        ("episode_index", Kind::I64),
        ("index", Kind::I64),
        ("task_index", Kind::I64),
    ]);
    c.into_iter().map(|(n, k)| (n.to_string(), k)).collect()
}

/// Frames of one or more consecutive episodes, column-wise, as stored.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameColumns {
    pub rows: usize,
    pub wheels: usize,
    /// Crop side (full variant), 0 without crops.
    pub crop: usize,
    pub state: Vec<f64>,
    pub goal: Vec<f64>,
    pub wheel_values: Vec<f32>,
    pub elevation: Vec<u16>,
    pub semantics: Vec<u16>,
    pub action: Vec<f32>,
    pub reward: Vec<f32>,
    pub reward_terms: Vec<f32>,
    pub done: Vec<bool>,
    pub terminated: Vec<bool>,
    pub truncated: Vec<bool>,
    pub timestamp: Vec<f32>,
    pub frame_index: Vec<i64>,
    pub episode_index: Vec<i64>,
    pub index: Vec<i64>,
    pub task_index: Vec<i64>,
}

/// `frame / fps` as stored in `timestamp`.
pub fn timestamp(frame: u64, fps: f64) -> f32 {
    (frame as f64 / fps) as f32
}

/// Bytes a frame takes uncompressed: what the data-file size threshold counts.
pub fn row_bytes(spec: &DatasetSpec) -> u64 {
    let doubles = 15 + 3;
    let floats = 4 * spec.wheels as u64 + 3 + 1 + 4 + 1;
    let crops = match spec.variant {
        Variant::Full => 2 * 2 * (spec.crop.size as u64).pow(2),
        Variant::Lite => 0,
    };
    8 * doubles + 4 * floats + 3 + 8 * 4 + crops
}

fn finite<T: Copy + Into<f64> + std::fmt::Display>(
    episode: u64,
    field: &str,
    values: &[T],
    limit: f64,
) -> Result<(), DatasetError> {
    match values.iter().position(|&v| {
        let v: f64 = v.into();
        !v.is_finite() || v.abs() > limit
    }) {
        None => Ok(()),
        Some(i) => Err(DatasetError::record(
            episode,
            field,
            format!(
                "value {i} is {} (values must be finite{})",
                values[i],
                if limit < f64::MAX {
                    " and within float16's range"
                } else {
                    ""
                }
            ),
        )),
    }
}

fn same_len(episode: u64, field: &str, len: usize, want: usize) -> Result<(), DatasetError> {
    if len == want {
        Ok(())
    } else {
        Err(DatasetError::record(
            episode,
            field,
            format!("{len} values, expected {want}"),
        ))
    }
}

/// Checks an episode against itself and the spec before anything of it is written.
pub fn check_record(
    rec: &RecordedEpisode,
    spec: &DatasetSpec,
    episode: u64,
) -> Result<(), DatasetError> {
    let f = &rec.frames;
    let n = f.len();
    if n == 0 {
        return Err(DatasetError::record(episode, "frames", "no frames"));
    }
    if rec.meta.kind != spec.kind {
        return Err(DatasetError::record(
            episode,
            "kind",
            format!("a {:?} episode in a {:?} dataset", rec.meta.kind, spec.kind),
        ));
    }
    same_len(episode, "goal", f.goal.len(), n)?;
    same_len(episode, "action", f.action.len(), n)?;
    same_len(episode, "reward_terms", f.reward_terms.len(), n)?;
    same_len(episode, "terminated", f.terminated.len(), n)?;
    same_len(episode, "truncated", f.truncated.len(), n)?;
    same_len(episode, "wheels", f.wheels.len(), n * spec.wheels * 4)?;
    finite(episode, "state", f.state.as_flattened(), f64::MAX)?;
    finite(episode, "goal", f.goal.as_flattened(), f64::MAX)?;
    finite(episode, "wheels", &f.wheels, f64::MAX)?;
    finite(episode, "action", f.action.as_flattened(), f64::MAX)?;
    finite(
        episode,
        "reward_terms",
        f.reward_terms.as_flattened(),
        f64::MAX,
    )?;
    let cells = n * spec.crop.size * spec.crop.size;
    for (field, crop) in [("elevation", &f.elevation), ("semantics", &f.semantics)] {
        match (spec.variant, crop) {
            (Variant::Full, Some(v)) => {
                same_len(episode, field, v.len(), cells)?;
                finite(episode, field, v, F16_MAX)?;
            }
            (Variant::Full, None) => {
                return Err(DatasetError::record(
                    episode,
                    field,
                    "missing: the full variant stores crops",
                ))
            }
            (Variant::Lite, Some(_)) => {
                return Err(DatasetError::record(
                    episode,
                    field,
                    "given to a lite dataset, which stores no crops",
                ))
            }
            (Variant::Lite, None) => {}
        }
    }
    let m = &rec.meta;
    let params_finite = m.policy_params.values().all(|v| v.is_finite());
    if !params_finite || !m.start.iter().chain(&m.goal).all(|v| v.is_finite()) {
        return Err(DatasetError::record(
            episode,
            "meta",
            "start, goal and policy parameters must be finite",
        ));
    }
    finite(episode, "final_state", &m.final_state, f64::MAX)?;
    finite(episode, "final_goal", &m.final_goal, f64::MAX)?;
    if let Some(w) = &m.failure {
        if !w.start_time.is_finite() {
            return Err(DatasetError::record(
                episode,
                "failure.start_time",
                "not finite",
            ));
        }
    }
    Ok(())
}

fn f16_bits(v: &[f32]) -> impl Iterator<Item = u16> + '_ {
    v.iter().map(|&x| half::f16::from_f32(x).to_bits())
}

impl FrameColumns {
    pub fn new(spec: &DatasetSpec) -> FrameColumns {
        FrameColumns {
            wheels: spec.wheels,
            crop: if spec.variant == Variant::Full {
                spec.crop.size
            } else {
                0
            },
            ..FrameColumns::default()
        }
    }

    /// Appends a checked episode ([`check_record`]) as episode `episode`, its first frame global index `first`.
    pub fn push(&mut self, rec: &RecordedEpisode, episode: u64, first: u64, task: u64, fps: f64) {
        let f = &rec.frames;
        self.state.extend(f.state.iter().flatten());
        self.goal.extend(f.goal.iter().flatten());
        self.wheel_values.extend(&f.wheels);
        if self.crop > 0 {
            self.elevation
                .extend(f16_bits(f.elevation.as_deref().unwrap_or_default()));
            self.semantics
                .extend(f16_bits(f.semantics.as_deref().unwrap_or_default()));
        }
        self.action.extend(f.action.iter().flatten());
        for t in &f.reward_terms {
            self.reward.push(t[0] + t[1] + t[2] + t[3]);
        }
        self.reward_terms.extend(f.reward_terms.iter().flatten());
        for (&te, &tr) in f.terminated.iter().zip(&f.truncated) {
            self.done.push(te || tr);
        }
        self.terminated.extend(&f.terminated);
        self.truncated.extend(&f.truncated);
        for k in 0..f.len() as u64 {
            self.timestamp.push(timestamp(k, fps));
            self.frame_index.push(k as i64);
            self.episode_index.push(episode as i64);
            self.index.push((first + k) as i64);
            self.task_index.push(task as i64);
        }
        self.rows += f.len();
    }

    pub fn clear(&mut self) {
        *self = FrameColumns {
            wheels: self.wheels,
            crop: self.crop,
            ..FrameColumns::default()
        };
    }

    /// The row ranges of the episodes in these frames, in order (by changes of `episode_index`).
    pub fn episode_ranges(&self) -> Vec<(i64, std::ops::Range<usize>)> {
        let mut out: Vec<(i64, std::ops::Range<usize>)> = Vec::new();
        for (i, &e) in self.episode_index.iter().enumerate() {
            match out.last_mut() {
                Some((last, r)) if *last == e => r.end = i + 1,
                _ => out.push((e, i..i + 1)),
            }
        }
        out
    }

    /// The columns for [`crate::parquet_io::write_table`], in [`columns`]' order.
    pub fn into_columns(self, spec: &DatasetSpec) -> Vec<(String, Kind, Data)> {
        let mut data = vec![
            Data::ListF64(self.state),
            Data::ListF64(self.goal),
            Data::ListF32(self.wheel_values),
        ];
        if spec.variant == Variant::Full {
            data.push(Data::ListF16(self.elevation));
            data.push(Data::ListF16(self.semantics));
        }
        data.extend([
            Data::ListF32(self.action),
            Data::F32(self.reward),
            Data::ListF32(self.reward_terms),
            Data::Bool(self.done),
            Data::Bool(self.terminated),
            Data::Bool(self.truncated),
            Data::F32(self.timestamp),
            Data::I64(self.frame_index),
            Data::I64(self.episode_index),
            Data::I64(self.index),
            Data::I64(self.task_index),
        ]);
        columns(spec)
            .into_iter()
            .zip(data)
            .map(|((n, k), d)| (n, k, d))
            .collect()
    }

    /// Frames from a table read with [`columns`]`(spec)`.
    pub fn from_table(spec: &DatasetSpec, table: Table) -> Result<FrameColumns, String> {
        let mut out = FrameColumns::new(spec);
        out.rows = table.rows;
        let names = columns(spec);
        for ((name, _), data) in names.iter().zip(table.columns) {
            match (name.as_str(), data) {
                ("observation.state", Data::ListF64(v)) => out.state = v,
                ("observation.goal", Data::ListF64(v)) => out.goal = v,
                ("observation.wheels", Data::ListF32(v)) => out.wheel_values = v,
                ("observation.elevation", Data::ListF16(v)) => out.elevation = v,
                ("observation.semantics", Data::ListF16(v)) => out.semantics = v,
                ("action", Data::ListF32(v)) => out.action = v,
                ("next.reward", Data::F32(v)) => out.reward = v,
                ("next.reward_terms", Data::ListF32(v)) => out.reward_terms = v,
                ("next.done", Data::Bool(v)) => out.done = v,
                ("next.terminated", Data::Bool(v)) => out.terminated = v,
                ("next.truncated", Data::Bool(v)) => out.truncated = v,
                ("timestamp", Data::F32(v)) => out.timestamp = v,
                ("frame_index", Data::I64(v)) => out.frame_index = v,
                ("episode_index", Data::I64(v)) => out.episode_index = v,
                ("index", Data::I64(v)) => out.index = v,
                ("task_index", Data::I64(v)) => out.task_index = v,
                (n, _) => return Err(format!("column `{n}`: unexpected values")),
            }
        }
        Ok(out)
    }
}
