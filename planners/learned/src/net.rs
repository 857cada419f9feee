//! [`PolicyNet`]: the actor of a `vertibench-policy-v1` weights file (`POLICY.md`), read from safetensors and
//! evaluated in `f32` in a fixed order, so the same inputs give the same actions on every machine and thread count.

use crate::features::{CROP_CHANNELS, CROP_SIZE, FEATURES, LAYOUT};
use crate::nn::{conv_relu, dense, expect_metadata, layer, open, sha256_hex, shape, Layer};
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
        let (metadata, st) = open(bytes)?;
        check_metadata(&metadata)?;
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

fn check_metadata(m: &BTreeMap<String, String>) -> Result<(), WeightsError> {
    let features = FEATURES.join(",");
    let actions = ACTIONS.join(",");
    expect_metadata(
        m,
        &[
            ("format", LAYOUT),
            ("features", features.as_str()),
            ("crop", CROP_META),
            ("crop_cell_per_scale", CROP_CELL_META),
            ("action", actions.as_str()),
        ],
    )?;
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
