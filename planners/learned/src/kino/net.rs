//! [`KinoNet`]: a `vertibench-kino-v1` weights file (`KINO.md`): a small CNN encoder of the elevation crop shared by
//! an ensemble of MLP heads, each predicting the change of pose over one model step (and the steering at its end).
//! The ensemble's spread is the model's uncertainty. Evaluated in `f32` in a fixed order for a batch of samples
//! (the rollouts of a sampling planner), with preallocated scratch: a prediction allocates nothing.

use super::features::{crop_features, Pose, CROP_SIZE, FEATURES, LAYOUT, TARGETS};
use crate::net::WeightsError;
use crate::nn::{conv_relu, dense, expect_metadata, layer, open, sha256_hex, shape, Layer};
use sim_core::world::World;
use std::collections::BTreeMap;

/// Conv1 and conv2: filters, kernel, stride (no padding), on the one-channel crop.
pub(crate) const CONV1: (usize, usize, usize) = (8, 3, 2);
pub(crate) const CONV2: (usize, usize, usize) = (16, 3, 2);
const SIDE1: usize = (CROP_SIZE - CONV1.1) / CONV1.2 + 1;
const SIDE2: usize = (SIDE1 - CONV2.1) / CONV2.2 + 1;
/// The flattened conv2 output and the terrain code it is reduced to.
const CONV_OUT: usize = CONV2.0 * SIDE2 * SIDE2;
pub const CODE: usize = 32;
/// Inputs of every head: the terrain code and the vector features.
pub const HEAD_INPUTS: usize = CODE + FEATURES.len();
/// What a weights file's `crop` metadata must say.
pub const CROP_META: &str = "1x16x16";

/// The ensemble model of a weights file, with its metadata and scratch buffers.
#[derive(Clone, Debug)]
pub struct KinoNet {
    conv1: Layer,
    conv2: Layer,
    code: Layer,
    heads: Heads,
    metadata: BTreeMap<String, String>,
    sha256: String,
    a1: Vec<f32>,
    a2: Vec<f32>,
    input: Vec<f32>,
    crop: Vec<f32>,
}

impl KinoNet {
    /// Reads a weights file's bytes, checking its layout, metadata and every tensor's dtype and shape.
    pub fn from_bytes(bytes: &[u8]) -> Result<KinoNet, WeightsError> {
        let (metadata, st) = open(bytes)?;
        let features = FEATURES.join(",");
        let targets = TARGETS.join(",");
        expect_metadata(
            &metadata,
            &[
                ("format", LAYOUT),
                ("features", features.as_str()),
                ("targets", targets.as_str()),
                ("crop", CROP_META),
            ],
        )?;
        let (c1, k1, _) = CONV1;
        let (c2, k2, _) = CONV2;
        let conv1 = layer(
            &st,
            ("enc.conv1.weight", "enc.conv1.bias"),
            &[c1, 1, k1, k1],
        )?;
        let conv2 = layer(
            &st,
            ("enc.conv2.weight", "enc.conv2.bias"),
            &[c2, c1, k2, k2],
        )?;
        let code = layer(&st, ("enc.code.weight", "enc.code.bias"), &[CODE, CONV_OUT])?;
        let heads = Heads::read(&st, &metadata)?;
        Ok(KinoNet {
            conv1,
            conv2,
            code,
            heads,
            metadata,
            sha256: sha256_hex(bytes),
            a1: vec![0.0; c1 * SIDE1 * SIDE1],
            a2: vec![0.0; CONV_OUT],
            input: vec![0.0; HEAD_INPUTS],
            crop: vec![0.0; CROP_SIZE * CROP_SIZE],
        })
    }

    /// The file's metadata (`KINO.md`).
    pub fn metadata(&self) -> &BTreeMap<String, String> {
        &self.metadata
    }

    /// SHA-256 of the weights file (hex).
    pub fn sha256(&self) -> &str {
        &self.sha256
    }

    /// Ensemble members.
    pub fn members(&self) -> usize {
        self.heads.members()
    }

    /// Every member's scaled outputs ([`TARGETS`], `members x 7` into `out`) for one sample's vector features and
    /// crop (`CROP_SIZE x CROP_SIZE`).
    ///
    /// # Panics
    /// If `crop` is shorter than a crop or `out` than `members x 7`.
    pub fn predict(&mut self, vector: &[f32; FEATURES.len()], crop: &[f32], out: &mut [f32]) {
        conv_relu(&self.conv1, CONV1, 1, CROP_SIZE, crop, &mut self.a1);
        conv_relu(&self.conv2, CONV2, CONV1.0, SIDE1, &self.a1, &mut self.a2);
        let (code, vec_in) = self.input.split_at_mut(CODE);
        dense(&self.code, &self.a2, code, false);
        code.iter_mut().for_each(|v| *v = v.max(0.0));
        vec_in.copy_from_slice(vector);
        self.heads.run(&self.input, out);
    }

    /// [`predict`](Self::predict) for a vehicle at `pose` on `world`, its crop taken there.
    pub fn predict_at(
        &mut self,
        world: &World,
        pose: &Pose,
        scale: f64,
        vector: &[f32; FEATURES.len()],
        out: &mut [f32],
    ) {
        let mut crop = std::mem::take(&mut self.crop);
        crop_features(world, pose, scale, &mut crop);
        self.predict(vector, &crop, out);
        self.crop = crop;
    }
}

/// One ensemble member: two tanh layers and the output.
#[derive(Clone, Debug)]
struct Head {
    fc1: Layer,
    fc2: Layer,
    out: Layer,
}

/// The ensemble of MLP heads both model layouts end in (`heads.M.*`): each maps a terrain code of [`CODE`] entries
/// and the vector features to the [`TARGETS`].
#[derive(Clone, Debug)]
pub(crate) struct Heads {
    heads: Vec<Head>,
    h1: Vec<f32>,
    h2: Vec<f32>,
}

impl Heads {
    /// The members the metadata's `ensemble` names, of the hidden width the first one has.
    pub(crate) fn read(
        st: &safetensors::SafeTensors<'_>,
        metadata: &BTreeMap<String, String>,
    ) -> Result<Heads, WeightsError> {
        let members: usize = metadata
            .get("ensemble")
            .and_then(|e| e.parse().ok())
            .filter(|&e| (1..=16).contains(&e))
            .ok_or_else(|| WeightsError::Metadata {
                key: "ensemble",
                found: metadata
                    .get("ensemble")
                    .map_or_else(|| "missing".into(), |e| format!("`{e}`")),
                expected: "a member count in 1..=16".into(),
            })?;
        let hidden = shape(st, HEAD_NAMES[0][0])?.first().copied().unwrap_or(0);
        if hidden == 0 {
            return Err(WeightsError::Tensor {
                name: HEAD_NAMES[0][0],
                problem: "has no rows".into(),
            });
        }
        let mut heads = Vec::with_capacity(members);
        for n in HEAD_NAMES.iter().take(members) {
            heads.push(Head {
                fc1: layer(st, (n[0], n[1]), &[hidden, HEAD_INPUTS])?,
                fc2: layer(st, (n[2], n[3]), &[hidden, hidden])?,
                out: layer(st, (n[4], n[5]), &[TARGETS.len(), hidden])?,
            });
        }
        Ok(Heads {
            heads,
            h1: vec![0.0; hidden],
            h2: vec![0.0; hidden],
        })
    }

    pub(crate) fn members(&self) -> usize {
        self.heads.len()
    }

    /// Every member's outputs (`members x 7` into `out`) for `input` ([`HEAD_INPUTS`]: code, then vector).
    pub(crate) fn run(&mut self, input: &[f32], out: &mut [f32]) {
        for (head, o) in self.heads.iter().zip(out.chunks_exact_mut(TARGETS.len())) {
            dense(&head.fc1, input, &mut self.h1, true);
            dense(&head.fc2, &self.h1, &mut self.h2, true);
            dense(&head.out, &self.h2, o, false);
        }
    }
}

/// Tensor names of the heads, in member order (`heads.N.fc1.weight`, ...), for up to 16 members.
const HEAD_NAMES: [[&str; 6]; 16] = {
    macro_rules! head {
        ($n:literal) => {
            [
                concat!("heads.", $n, ".fc1.weight"),
                concat!("heads.", $n, ".fc1.bias"),
                concat!("heads.", $n, ".fc2.weight"),
                concat!("heads.", $n, ".fc2.bias"),
                concat!("heads.", $n, ".out.weight"),
                concat!("heads.", $n, ".out.bias"),
            ]
        };
    }
    [
        head!(0),
        head!(1),
        head!(2),
        head!(3),
        head!(4),
        head!(5),
        head!(6),
        head!(7),
        head!(8),
        head!(9),
        head!(10),
        head!(11),
        head!(12),
        head!(13),
        head!(14),
        head!(15),
    ]
};
