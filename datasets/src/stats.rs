//! `meta/stats.json`: per numeric feature and component, mean, std (population), min, max and count, as LeRobot
//! writes them. Computed in a fixed order (episode by episode, each with two passes, merged with Chan's formula),
//! so the same frames give the same bytes however they were written or resumed, and `validate` can recompute
//! them.

use crate::frames::FrameColumns;
use crate::json::Ordered;
use crate::spec::{DatasetSpec, Variant};
use serde::Serialize;
use serde_json::Value;

/// How a feature's values are stored (and so how its min and max are written).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Dtype {
    /// float64: min and max written as such.
    Double,
    Float,
    Int,
    Bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
struct Component {
    n: u64,
    mean: f64,
    m2: f64,
    min: f64,
    max: f64,
}

impl Component {
    const EMPTY: Component = Component {
        n: 0,
        mean: 0.0,
        m2: 0.0,
        min: f64::INFINITY,
        max: f64::NEG_INFINITY,
    };

    fn merge(&mut self, o: &Component) {
        if o.n == 0 {
            return;
        }
        if self.n == 0 {
            *self = *o;
            return;
        }
        let (na, nb) = (self.n as f64, o.n as f64);
        let n = na + nb;
        let delta = o.mean - self.mean;
        self.mean += delta * nb / n;
        self.m2 += o.m2 + delta * delta * na * nb / n;
        self.n += o.n;
        self.min = self.min.min(o.min);
        self.max = self.max.max(o.max);
    }
}

#[derive(Clone, Debug, PartialEq)]
struct Feature {
    name: &'static str,
    shape: Vec<usize>,
    dtype: Dtype,
    comps: Vec<Component>,
}

/// Running statistics of a dataset's frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    features: Vec<Feature>,
}

/// A feature's values, row-major, as stored.
enum View<'a> {
    F64(&'a [f64]),
    F32(&'a [f32]),
    F16(&'a [u16]),
    I64(&'a [i64]),
    Bool(&'a [bool]),
}

fn view<'a>(f: &'a FrameColumns, name: &str) -> View<'a> {
    match name {
        "observation.state" => View::F64(&f.state),
        "observation.goal" => View::F64(&f.goal),
        "observation.wheels" => View::F32(&f.wheel_values),
        "observation.elevation" => View::F16(&f.elevation),
        "observation.semantics" => View::F16(&f.semantics),
        "action" => View::F32(&f.action),
        "next.reward" => View::F32(&f.reward),
        "next.reward_terms" => View::F32(&f.reward_terms),
        "next.done" => View::Bool(&f.done),
        "next.terminated" => View::Bool(&f.terminated),
        "next.truncated" => View::Bool(&f.truncated),
        "timestamp" => View::F32(&f.timestamp),
        "frame_index" => View::I64(&f.frame_index),
        "episode_index" => View::I64(&f.episode_index),
        "index" => View::I64(&f.index),
        _ => View::I64(&f.task_index),
    }
}

/// Statistics of rows `rows` of one feature with `d` components: two passes (sum, then squared deviations), in
/// row order.
fn episode_stats<T: Copy>(
    v: &[T],
    x: impl Fn(T) -> f64,
    d: usize,
    rows: std::ops::Range<usize>,
) -> Vec<Component> {
    let n = rows.len();
    let mut out = vec![Component::EMPTY; d];
    let Some(values) = v.get(rows.start * d..rows.end * d) else {
        return out;
    };
    if n == 0 || d == 0 {
        return out;
    }
    let mut sum = vec![0.0f64; d];
    for row in values.chunks_exact(d) {
        for ((s, o), &val) in sum.iter_mut().zip(out.iter_mut()).zip(row) {
            let val = x(val);
            *s += val;
            o.min = o.min.min(val);
            o.max = o.max.max(val);
        }
    }
    for (o, s) in out.iter_mut().zip(&sum) {
        o.n = n as u64;
        o.mean = s / n as f64;
    }
    for row in values.chunks_exact(d) {
        for (o, &val) in out.iter_mut().zip(row) {
            let dx = x(val) - o.mean;
            o.m2 += dx * dx;
        }
    }
    out
}

impl Stats {
    pub fn new(spec: &DatasetSpec) -> Stats {
        let f = |name, shape: Vec<usize>, dtype| Feature {
            name,
            comps: vec![Component::EMPTY; shape.iter().product()],
            shape,
            dtype,
        };
        let mut features = vec![
            f("observation.state", vec![15], Dtype::Double),
            f("observation.goal", vec![3], Dtype::Double),
            f("observation.wheels", vec![spec.wheels, 4], Dtype::Float),
        ];
        if spec.variant == Variant::Full {
            let s = spec.crop.size;
            features.push(f("observation.elevation", vec![s, s], Dtype::Float));
            features.push(f("observation.semantics", vec![s, s], Dtype::Float));
        }
        features.extend([
            f("action", vec![3], Dtype::Float),
            f("next.reward", vec![1], Dtype::Float),
            f("next.reward_terms", vec![4], Dtype::Float),
            f("next.done", vec![1], Dtype::Bool),
            f("next.terminated", vec![1], Dtype::Bool),
            f("next.truncated", vec![1], Dtype::Bool),
            f("timestamp", vec![1], Dtype::Float),
            f("frame_index", vec![1], Dtype::Int),
            f("episode_index", vec![1], Dtype::Int),
            f("index", vec![1], Dtype::Int),
            f("task_index", vec![1], Dtype::Int),
        ]);
        Stats { features }
    }

    /// Adds the frames of a data file, episode by episode.
    pub fn add(&mut self, frames: &FrameColumns) {
        let ranges = frames.episode_ranges();
        for feat in &mut self.features {
            let v = view(frames, feat.name);
            let d = feat.comps.len();
            for (_, rows) in &ranges {
                let r = rows.clone();
                let e = match v {
                    View::F64(v) => episode_stats(v, |x| x, d, r),
                    View::F32(v) => episode_stats(v, f64::from, d, r),
                    View::F16(v) => {
                        episode_stats(v, |b| f64::from(half::f16::from_bits(b).to_f32()), d, r)
                    }
                    View::I64(v) => episode_stats(v, |i| i as f64, d, r),
                    View::Bool(v) => episode_stats(v, |b| f64::from(u8::from(b)), d, r),
                };
                for (acc, e) in feat.comps.iter_mut().zip(e) {
                    acc.merge(&e);
                }
            }
        }
    }

    /// Frames counted.
    pub fn count(&self) -> u64 {
        self.features
            .first()
            .and_then(|f| f.comps.first())
            .map_or(0, |c| c.n)
    }

    /// The bytes of `meta/stats.json` (no features when there are no frames).
    pub fn to_bytes(&self, path: &std::path::Path) -> Result<Vec<u8>, crate::DatasetError> {
        let mut out = Vec::new();
        if self.count() > 0 {
            for f in &self.features {
                let num = |x: f64| match f.dtype {
                    Dtype::Double => Num::D(x),
                    Dtype::Float => Num::F(x as f32),
                    Dtype::Int => Num::I(x as i64),
                    Dtype::Bool => Num::B(x != 0.0),
                };
                let std = |c: &Component| (c.m2 / c.n.max(1) as f64).max(0.0).sqrt();
                out.push((
                    f.name.to_string(),
                    FeatureStats {
                        min: shaped(&f.shape, f.comps.iter().map(|c| num(c.min)).collect()),
                        max: shaped(&f.shape, f.comps.iter().map(|c| num(c.max)).collect()),
                        mean: shaped(&f.shape, f.comps.iter().map(|c| c.mean).collect()),
                        std: shaped(&f.shape, f.comps.iter().map(std).collect()),
                        count: [f.comps.first().map_or(0, |c| c.n)],
                    },
                ));
            }
        }
        crate::json::to_bytes(path, &Ordered(out))
    }
}

/// A min or max as its feature's type writes it (float64, float32 in its shortest form, integer, boolean).
#[derive(Clone, Copy, Debug, Serialize)]
#[serde(untagged)]
enum Num {
    D(f64),
    F(f32),
    I(i64),
    B(bool),
}

/// Values nested into a feature's shape.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
enum Nested<T> {
    Leaf(Vec<T>),
    List(Vec<Nested<T>>),
}

#[derive(Clone, Debug, Serialize)]
struct FeatureStats {
    min: Nested<Num>,
    max: Nested<Num>,
    mean: Nested<f64>,
    std: Nested<f64>,
    count: [u64; 1],
}

/// Nests a row-major list of values into `shape` (a `[n]` shape is a flat list, `[1]` one value in a list, as
/// LeRobot writes).
fn shaped<T>(shape: &[usize], values: Vec<T>) -> Nested<T> {
    match shape {
        [] | [_] => Nested::Leaf(values),
        [_, rest @ ..] => {
            let inner: usize = rest.iter().product::<usize>().max(1);
            let mut it = values.into_iter();
            let mut out = Vec::new();
            loop {
                let chunk: Vec<T> = it.by_ref().take(inner).collect();
                if chunk.is_empty() {
                    break;
                }
                out.push(shaped(rest, chunk));
            }
            Nested::List(out)
        }
    }
}

/// The first difference between two stats documents (a recorded and a recomputed one), with a relative tolerance
/// for the floating-point values: `None` when they agree.
pub fn first_difference(recorded: &Value, recomputed: &Value, at: &str) -> Option<String> {
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs()).max(1e-9) || a == b;
    match (recorded, recomputed) {
        (Value::Object(a), Value::Object(b)) => {
            for (k, vb) in b {
                let path = if at.is_empty() {
                    k.clone()
                } else {
                    format!("{at}.{k}")
                };
                match a.get(k) {
                    None => return Some(format!("`{path}` is missing")),
                    Some(va) => {
                        if let Some(d) = first_difference(va, vb, &path) {
                            return Some(d);
                        }
                    }
                }
            }
            a.keys().find(|k| !b.contains_key(*k)).map(|k| {
                format!(
                    "`{at}{}{k}` is not a feature of the data",
                    if at.is_empty() { "" } else { "." }
                )
            })
        }
        (Value::Array(a), Value::Array(b)) if a.len() == b.len() => a
            .iter()
            .zip(b)
            .enumerate()
            .find_map(|(i, (x, y))| first_difference(x, y, &format!("{at}[{i}]"))),
        (Value::Number(a), Value::Number(b)) => match (a.as_f64(), b.as_f64()) {
            (Some(x), Some(y)) if close(x, y) => None,
            _ => Some(format!("`{at}` is {a}, the data give {b}")),
        },
        (a, b) if a == b => None,
        (a, b) => Some(format!("`{at}` is {a}, the data give {b}")),
    }
}
