//! `meta/info.json`: LeRobot v3's dataset description (codebase version, fps, totals, file layout, features with
//! dtype, shape and names) plus a `vertibench` object (format, completeness, the spec, the command line, the
//! writer's options and totals).

use crate::error::DatasetError;
use crate::json::Ordered;
use crate::layout::DATA_PATH_TEMPLATE;
use crate::record::{ACTION_FIELDS, GOAL_FIELDS, REWARD_TERMS, STATE_FIELDS, WHEEL_FIELDS};
use crate::spec::{DatasetSpec, Variant};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;

/// LeRobot's dataset format version.
pub const CODEBASE_VERSION: &str = "v3.0";
/// This crate's layout version (`vertibench.format`).
pub const FORMAT: &str = "vertibench-dataset/1";

/// The writer options that shape the files (part of a dataset's identity, with its spec).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Layout {
    /// A data file is closed once its frames reach this many MB (10^6 bytes) uncompressed.
    pub data_files_size_in_mb: f64,
    /// Files per `chunk-NNN` directory.
    pub chunks_size: u64,
}

/// A feature as `info.json` describes it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Feature {
    pub dtype: String,
    pub shape: Vec<usize>,
    pub names: Value,
}

/// Totals of a dataset.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Totals {
    pub episodes: u64,
    pub frames: u64,
    pub data_files: u64,
    pub simulated_seconds: f64,
    pub simulated_hours: f64,
}

/// The `vertibench` object of `info.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VertibenchInfo {
    pub format: String,
    /// True once the run finished (`finish`); a dataset being written or interrupted says false.
    pub complete: bool,
    pub spec: DatasetSpec,
    pub command: String,
    pub layout: Layout,
    pub totals: Totals,
    /// The SHA-256 of every completed data and episode metadata file (`sha256:<hex>`, by relative path), so
    /// `validate` names a file whose bytes changed.
    #[serde(default)]
    pub checksums: BTreeMap<String, String>,
}

/// `meta/info.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Info {
    pub codebase_version: String,
    pub robot_type: String,
    pub total_episodes: u64,
    pub total_frames: u64,
    pub total_tasks: u64,
    pub chunks_size: u64,
    pub data_files_size_in_mb: Value,
    pub fps: Value,
    pub splits: BTreeMap<String, String>,
    pub data_path: String,
    pub video_path: Option<String>,
    pub features: Ordered<Feature>,
    pub vertibench: VertibenchInfo,
}

/// `info.json` as read back (features in any order).
#[derive(Clone, Debug, Deserialize)]
pub struct InfoIn {
    pub codebase_version: String,
    pub robot_type: String,
    pub total_episodes: u64,
    pub total_frames: u64,
    pub total_tasks: u64,
    pub chunks_size: u64,
    pub data_files_size_in_mb: f64,
    pub fps: f64,
    pub splits: BTreeMap<String, String>,
    pub data_path: String,
    pub features: BTreeMap<String, Feature>,
    pub vertibench: VertibenchInfo,
}

/// A number written as an integer when it is one (LeRobot's `fps` and sizes are integers).
pub fn number(x: f64) -> Value {
    if x.fract() == 0.0 && x.abs() < 9.0e15 {
        Value::from(x as i64)
    } else {
        Value::from(x)
    }
}

fn feature(dtype: &str, shape: Vec<usize>, names: Value) -> Feature {
    Feature {
        dtype: dtype.into(),
        shape,
        names,
    }
}

/// The features of a spec's frames, in column order. Names list a 1-D feature's components; for 2-D features
/// they name the axes and the wheel fields.
pub fn features(spec: &DatasetSpec) -> Ordered<Feature> {
    let names = |n: &[&str]| Value::from(n.to_vec());
    let mut f = vec![
        (
            "observation.state",
            feature("float64", vec![15], names(&STATE_FIELDS)),
        ),
        (
            "observation.goal",
            feature("float64", vec![3], names(&GOAL_FIELDS)),
        ),
        (
            "observation.wheels",
            feature(
                "float32",
                vec![spec.wheels, 4],
                serde_json::json!({"axes": ["wheel", "field"], "field": WHEEL_FIELDS}),
            ),
        ),
    ];
    if spec.variant == Variant::Full {
        let s = spec.crop.size;
        let axes = names(&["row", "column"]);
        f.push((
            "observation.elevation",
            feature("float16", vec![s, s], axes.clone()),
        ));
        f.push((
            "observation.semantics",
            feature("float16", vec![s, s], axes),
        ));
    }
    f.extend([
        ("action", feature("float32", vec![3], names(&ACTION_FIELDS))),
        ("next.reward", feature("float32", vec![1], Value::Null)),
        (
            "next.reward_terms",
            feature("float32", vec![4], names(&REWARD_TERMS)),
        ),
        ("next.done", feature("bool", vec![1], Value::Null)),
        ("next.terminated", feature("bool", vec![1], Value::Null)),
        ("next.truncated", feature("bool", vec![1], Value::Null)),
        ("timestamp", feature("float32", vec![1], Value::Null)),
        ("frame_index", feature("int64", vec![1], Value::Null)),
        ("episode_index", feature("int64", vec![1], Value::Null)),
        ("index", feature("int64", vec![1], Value::Null)),
        ("task_index", feature("int64", vec![1], Value::Null)),
    ]);
    Ordered(f.into_iter().map(|(n, f)| (n.to_string(), f)).collect())
}

/// Builds `info.json`'s content.
pub fn info(vertibench: VertibenchInfo, total_tasks: u64) -> Info {
    let (spec, layout, totals) = (&vertibench.spec, &vertibench.layout, &vertibench.totals);
    Info {
        codebase_version: CODEBASE_VERSION.into(),
        robot_type: spec.vehicle.to_string(),
        total_episodes: totals.episodes,
        total_frames: totals.frames,
        total_tasks,
        chunks_size: layout.chunks_size,
        data_files_size_in_mb: number(layout.data_files_size_in_mb),
        fps: number(spec.control_rate_hz),
        splits: BTreeMap::from([("train".to_string(), format!("0:{}", totals.episodes))]),
        data_path: DATA_PATH_TEMPLATE.into(),
        video_path: None,
        features: features(spec),
        vertibench,
    }
}

/// `sha256:<hex>` of a file's bytes.
pub fn checksum(bytes: &[u8]) -> String {
    use sha2::Digest;
    let digest = sha2::Sha256::digest(bytes);
    let mut s = String::from("sha256:");
    for b in digest {
        s += &format!("{b:02x}");
    }
    s
}

/// Reads `info.json`.
pub fn read_info(path: &Path) -> Result<InfoIn, DatasetError> {
    crate::json::read(path)
}

/// The fields in which two specs (and layouts) differ, as `field: there X, here Y`.
pub fn differences(there: (&DatasetSpec, &Layout), here: (&DatasetSpec, &Layout)) -> Vec<String> {
    let flat = |spec: &DatasetSpec, layout: &Layout| {
        let mut m = BTreeMap::new();
        for (prefix, v) in [
            ("", serde_json::to_value(spec)),
            ("", serde_json::to_value(layout)),
        ] {
            if let Ok(Value::Object(o)) = v {
                for (k, v) in o {
                    m.insert(format!("{prefix}{k}"), v.to_string());
                }
            }
        }
        m
    };
    let (a, b) = (flat(there.0, there.1), flat(here.0, here.1));
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            let show =
                |m: &BTreeMap<String, String>| m.get(k).cloned().unwrap_or_else(|| "none".into());
            format!("`{k}`: {} there, {} here", show(&a), show(&b))
        })
        .collect()
}
