//! [`PolicyNet`]: the actor of a `vertibench-policy-v1` weights file (`POLICY.md`), read from safetensors and
//! evaluated in `f32` in a fixed order, so the same inputs give the same actions on every machine and thread count.

use crate::features::{CROP_CHANNELS, CROP_SIZE, FEATURES, LAYOUT};
use safetensors::tensor::{Dtype, SafeTensors};
use std::collections::BTreeMap;

/// Conv1: filters, kernel, stride; conv2 likewise (no padding).
const CONV1: (usize, usize, usize) = (8, 4, 2);
const CONV2: (usize, usize, usize) = (16, 3, 2);
/// Side of conv1's and conv2's outputs.
const SIDE1: usize = (CROP_SIZE - CONV1.1) / CONV1.2 + 1;
const SIDE2: usize = (SIDE1 - CONV2.1) / CONV2.2 + 1;
/// Inputs of the actor's first layer: the flattened crop code and the vector features.
pub const ACTOR_INPUTS: usize = CONV2.0 * SIDE2 * SIDE2 + FEATURES.len();
/// Actions a policy outputs: steering, throttle.
pub const ACTIONS: [&str; 2] = ["steering", "throttle"];
/// What a weights file's `crop` metadata must say, and its `crop_cell_per_scale`.
pub const CROP_META: &str = "2x16x16";
pub const CROP_CELL_META: &str = "1.0";

/// Why a weights file was refused.
#[derive(Debug, thiserror::Error)]
pub enum WeightsError {
    #[error("not a safetensors file: {0}")]
    Format(String),
    #[error("metadata `{key}` is {found}; this build reads {expected}")]
    Metadata {
        key: &'static str,
        found: String,
        expected: String,
    },
    #[error("tensor `{name}`: {problem}")]
    Tensor { name: &'static str, problem: String },
}

#[derive(Clone, Debug)]
struct Layer {
    /// Row-major `[out, in]` (convolutions: `[out, in_channels, k, k]`).
    weight: Vec<f32>,
    bias: Vec<f32>,
}

/// The actor network of a weights file, with its metadata and scratch buffers (acting allocates nothing).
#[derive(Clone, Debug)]
pub struct PolicyNet {
    conv1: Layer,
    conv2: Layer,
    fc1: Layer,
    fc2: Layer,
    mean: Layer,
    metadata: BTreeMap<String, String>,
    sha256: String,
    a1: Vec<f32>,
    a2: Vec<f32>,
    h1: Vec<f32>,
    h2: Vec<f32>,
}

impl PolicyNet {
    /// Reads a weights file's bytes, checking its layout, metadata and every tensor's dtype and shape.
    pub fn from_bytes(bytes: &[u8]) -> Result<PolicyNet, WeightsError> {
        let (_, header) =
            SafeTensors::read_metadata(bytes).map_err(|e| WeightsError::Format(e.to_string()))?;
        let metadata: BTreeMap<String, String> = header
            .metadata()
            .as_ref()
            .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
            .unwrap_or_default();
        check_metadata(&metadata)?;
        let st =
            SafeTensors::deserialize(bytes).map_err(|e| WeightsError::Format(e.to_string()))?;
        let (c1, k1, _) = CONV1;
        let (c2, k2, _) = CONV2;
        let conv1 = layer(
            &st,
            ("enc.conv1.weight", "enc.conv1.bias"),
            &[c1, CROP_CHANNELS, k1, k1],
        )?;
        let conv2 = layer(
            &st,
            ("enc.conv2.weight", "enc.conv2.bias"),
            &[c2, c1, k2, k2],
        )?;
        let hidden = shape(&st, "pi.fc1.weight")?.first().copied().unwrap_or(0);
        if hidden == 0 {
            return Err(WeightsError::Tensor {
                name: "pi.fc1.weight",
                problem: "has no rows".into(),
            });
        }
        let fc1 = layer(
            &st,
            ("pi.fc1.weight", "pi.fc1.bias"),
            &[hidden, ACTOR_INPUTS],
        )?;
        let fc2 = layer(&st, ("pi.fc2.weight", "pi.fc2.bias"), &[hidden, hidden])?;
        let mean = layer(
            &st,
            ("pi.mean.weight", "pi.mean.bias"),
            &[ACTIONS.len(), hidden],
        )?;
        Ok(PolicyNet {
            conv1,
            conv2,
            fc1,
            fc2,
            mean,
            metadata,
            sha256: sha256_hex(bytes),
            a1: vec![0.0; c1 * SIDE1 * SIDE1],
            a2: vec![0.0; ACTOR_INPUTS],
            h1: vec![0.0; hidden],
            h2: vec![0.0; hidden],
        })
    }

    /// The file's metadata (`POLICY.md`: format, features, crop, control rate, vehicle, name, card entries).
    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// SHA-256 of the weights file (hex): what identifies a policy in `planner.json` and the cards.
    pub fn sha256(&self) -> &str {
        &self.sha256
    }

    /// Width of the actor's hidden layers.
    pub fn hidden(&self) -> usize {
        self.h1.len()
    }

    /// The deterministic action (steering, throttle), each clamped to [-1, 1], for the vector features and the crop
    /// features (`CROP_CHANNELS x CROP_SIZE x CROP_SIZE`).
    ///
    /// # Panics
    /// If `crop` has fewer entries than a crop.
    pub fn act(&mut self, vector: &[f32; FEATURES.len()], crop: &[f32]) -> [f32; 2] {
        conv_relu(
            &self.conv1,
            CONV1,
            CROP_CHANNELS,
            CROP_SIZE,
            crop,
            &mut self.a1,
        );
        let code = CONV2.0 * SIDE2 * SIDE2;
        let (conv_out, vec_out) = self.a2.split_at_mut(code);
        conv_relu(&self.conv2, CONV2, CONV1.0, SIDE1, &self.a1, conv_out);
        vec_out.copy_from_slice(vector);
        dense(&self.fc1, &self.a2, &mut self.h1, true);
        dense(&self.fc2, &self.h1, &mut self.h2, true);
        let mut out = [0.0f32; 2];
        dense(&self.mean, &self.h2, &mut out, false);
        out.map(|a| if a.is_nan() { 0.0 } else { a.clamp(-1.0, 1.0) })
    }
}

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

fn check_metadata(m: &BTreeMap<String, String>) -> Result<(), WeightsError> {
    let features = FEATURES.join(",");
    let actions = ACTIONS.join(",");
    for (key, expected) in [
        ("format", LAYOUT),
        ("features", features.as_str()),
        ("crop", CROP_META),
        ("crop_cell_per_scale", CROP_CELL_META),
        ("action", actions.as_str()),
    ] {
        let found = m.get(key);
        if found.map(String::as_str) != Some(expected) {
            return Err(WeightsError::Metadata {
                key,
                found: found.map_or_else(|| "missing".to_string(), |f| format!("`{f}`")),
                expected: format!("`{expected}`"),
            });
        }
    }
    if let Some(rate) = m.get("control_rate_hz") {
        if !rate.parse::<f64>().is_ok_and(|r| r.is_finite() && r > 0.0) {
            return Err(WeightsError::Metadata {
                key: "control_rate_hz",
                found: format!("`{rate}`"),
                expected: "a positive number".into(),
            });
        }
    }
    Ok(())
}

fn shape(st: &SafeTensors<'_>, name: &'static str) -> Result<Vec<usize>, WeightsError> {
    st.tensor(name)
        .map(|t| t.shape().to_vec())
        .map_err(|_| WeightsError::Tensor {
            name,
            problem: "missing".into(),
        })
}

fn tensor(
    st: &SafeTensors<'_>,
    name: &'static str,
    want: &[usize],
) -> Result<Vec<f32>, WeightsError> {
    let t = st.tensor(name).map_err(|_| WeightsError::Tensor {
        name,
        problem: "missing".into(),
    })?;
    if t.dtype() != Dtype::F32 {
        return Err(WeightsError::Tensor {
            name,
            problem: format!("dtype {:?}, expected F32", t.dtype()),
        });
    }
    if t.shape() != want {
        return Err(WeightsError::Tensor {
            name,
            problem: format!("shape {:?}, expected {want:?}", t.shape()),
        });
    }
    let values: Vec<f32> = t
        .data()
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(WeightsError::Tensor {
            name,
            problem: format!("entry {i} is {}", values[i]),
        });
    }
    Ok(values)
}

fn layer(
    st: &SafeTensors<'_>,
    (weight, bias): (&'static str, &'static str),
    want: &[usize],
) -> Result<Layer, WeightsError> {
    Ok(Layer {
        weight: tensor(st, weight, want)?,
        bias: tensor(st, bias, &want[..1])?,
    })
}

/// A valid (no padding) convolution of `input` (`in_ch x side x side`) with a ReLU, into `out`.
fn conv_relu(
    l: &Layer,
    (filters, k, stride): (usize, usize, usize),
    in_ch: usize,
    side: usize,
    input: &[f32],
    out: &mut [f32],
) {
    let out_side = (side - k) / stride + 1;
    for f in 0..filters {
        let wf = &l.weight[f * in_ch * k * k..(f + 1) * in_ch * k * k];
        for y in 0..out_side {
            for x in 0..out_side {
                let mut acc = l.bias[f];
                for c in 0..in_ch {
                    for ky in 0..k {
                        let row = &input[(c * side + y * stride + ky) * side + x * stride..];
                        let wr = &wf[(c * k + ky) * k..(c * k + ky + 1) * k];
                        for (w, v) in wr.iter().zip(row) {
                            acc += w * v;
                        }
                    }
                }
                out[(f * out_side + y) * out_side + x] = acc.max(0.0);
            }
        }
    }
}

/// `out = W input + b`, then tanh where asked.
fn dense(l: &Layer, input: &[f32], out: &mut [f32], tanh: bool) {
    let n = input.len();
    for (o, v) in out.iter_mut().enumerate() {
        let acc = l.bias[o]
            + l.weight[o * n..(o + 1) * n]
                .iter()
                .zip(input)
                .map(|(w, x)| w * x)
                .sum::<f32>();
        *v = if tanh { acc.tanh() } else { acc };
    }
}
