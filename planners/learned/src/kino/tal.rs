//! [`TalNet`]: the terrain-attentive kinodynamic model (`tal`, layout [`TAL_LAYOUT`], `KINO.md`), after TAL (Datar
//! et al., IROS 2024): the map is encoded **once per planning decision**, from a larger heading-aligned crop taken
//! at the decision's pose (the anchor), and every rollout step attends to the part of that embedding its predicted
//! pose is over: the pose's offset from the anchor ([`offset_features`]) drives a sigmoid gate multiplied element-wise
//! with the embedding (the release's "terrain attention"), which a dense layer fuses into the terrain code the
//! ensemble heads read, with the same vector features and targets as `vertibench-kino-v1`.
//!
//! So a rollout step needs no crop of the world (the kino model takes one per step), and the map's convolutions run
//! once per decision instead of once per sample and step. Training draws each sample's anchor from up to
//! [`ANCHOR_STEPS`] model steps before it, as a rollout of that many steps sees it.

use super::features::{heading_crop, pose_delta, Pose, FEATURES, TARGETS};
use super::net::{Heads, CODE, CONV1, CONV2};
use crate::features::clip;
use crate::net::WeightsError;
use crate::nn::{conv_relu, dense, expect_metadata, layer, open, sha256_hex, Layer};
use sim_core::world::World;
use std::collections::BTreeMap;

/// Version of the terrain-attentive model's inputs and network shape.
pub const TAL_LAYOUT: &str = "vertibench-tal-v1";
/// Map cells per side, metres per cell and how far ahead of the anchor the map is centred (scale 1): 16 m x 16 m
/// from 3 m behind to 13 m ahead, what a 2 s rollout at the nominal 4 m/s crosses.
pub const MAP_SIZE: usize = 32;
pub const MAP_CELL_PER_SCALE: f64 = 0.5;
pub const MAP_AHEAD_PER_SCALE: f64 = 5.0;
/// What a weights file's `map` metadata must say.
pub const MAP_META: &str = "1x32x32";
/// Model steps one map serves: training draws a sample's anchor from 0 to `ANCHOR_STEPS - 1` steps before it; the
/// planner's rollouts are this long.
pub const ANCHOR_STEPS: usize = 8;
/// Names of the offset features: the pose relative to the anchor, in the anchor's heading frame.
pub const OFFSETS: [&str; 5] = ["forward", "left", "up", "sin_yaw", "cos_yaw"];
/// Metres (x scale) the horizontal and vertical offsets are divided by.
const OFFSET_M: f64 = 8.0;
const UP_M: f64 = 2.0;

const SIDE1: usize = (MAP_SIZE - CONV1.1) / CONV1.2 + 1;
const SIDE2: usize = (SIDE1 - CONV2.1) / CONV2.2 + 1;
/// The map embedding (conv2's output, flattened `c, y, x`) and the gate's hidden width.
pub const EMBED: usize = CONV2.0 * SIDE2 * SIDE2;
pub const GATE_HIDDEN: usize = 32;

/// The map for an anchor `pose` (`MAP_SIZE x MAP_SIZE` into `out`, as the kino crop: heights relative to the
/// pose's, / 2 m x scale, row 0 ahead, column 0 left).
///
/// # Panics
/// If `out` holds fewer than `MAP_SIZE^2` entries.
pub fn map_features(world: &World, anchor: &Pose, scale: f64, out: &mut [f32]) {
    heading_crop(
        world,
        anchor,
        scale,
        (MAP_SIZE, MAP_CELL_PER_SCALE, MAP_AHEAD_PER_SCALE),
        out,
    );
}

/// The offset of `pose` from `anchor` ([`OFFSETS`]): forward and left / 8 m x scale and up / 2 m x scale in the
/// anchor's heading frame, and the sine and cosine of the change of heading.
pub fn offset_features(anchor: &Pose, pose: &Pose, scale: f64) -> [f32; OFFSETS.len()] {
    let d = pose_delta(anchor, pose);
    let (h, v) = (OFFSET_M * scale, UP_M * scale);
    [
        clip(d[0] / h),
        clip(d[1] / h),
        clip(d[2] / v),
        d[5].sin() as f32,
        d[5].cos() as f32,
    ]
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x).exp())
}

/// A `vertibench-tal-v1` weights file: map encoder, offset gate, fusion and ensemble heads, with scratch buffers
/// (a prediction allocates nothing) and the current anchor.
#[derive(Clone, Debug)]
pub struct TalNet {
    conv1: Layer,
    conv2: Layer,
    gate1: Layer,
    gate2: Layer,
    fuse: Layer,
    heads: Heads,
    metadata: BTreeMap<String, String>,
    sha256: String,
    map: Vec<f32>,
    a1: Vec<f32>,
    embed: Vec<f32>,
    g1: Vec<f32>,
    gated: Vec<f32>,
    input: Vec<f32>,
    anchor: Pose,
    scale: f64,
}

impl TalNet {
    /// Reads a weights file's bytes, checking its layout, metadata and every tensor's dtype and shape.
    pub fn from_bytes(bytes: &[u8]) -> Result<TalNet, WeightsError> {
        let (metadata, st) = open(bytes)?;
        let (features, targets, offsets) =
            (FEATURES.join(","), TARGETS.join(","), OFFSETS.join(","));
        expect_metadata(
            &metadata,
            &[
                ("format", TAL_LAYOUT),
                ("features", features.as_str()),
                ("targets", targets.as_str()),
                ("offsets", offsets.as_str()),
                ("map", MAP_META),
            ],
        )?;
        let (c1, k1, _) = CONV1;
        let (c2, k2, _) = CONV2;
        let l = |w, b, shape: &[usize]| layer(&st, (w, b), shape);
        Ok(TalNet {
            conv1: l("enc.conv1.weight", "enc.conv1.bias", &[c1, 1, k1, k1])?,
            conv2: l("enc.conv2.weight", "enc.conv2.bias", &[c2, c1, k2, k2])?,
            gate1: l(
                "att.gate1.weight",
                "att.gate1.bias",
                &[GATE_HIDDEN, OFFSETS.len()],
            )?,
            gate2: l("att.gate2.weight", "att.gate2.bias", &[EMBED, GATE_HIDDEN])?,
            fuse: l("att.fuse.weight", "att.fuse.bias", &[CODE, EMBED])?,
            heads: Heads::read(&st, &metadata)?,
            metadata,
            sha256: sha256_hex(bytes),
            map: vec![0.0; MAP_SIZE * MAP_SIZE],
            a1: vec![0.0; c1 * SIDE1 * SIDE1],
            embed: vec![0.0; EMBED],
            g1: vec![0.0; GATE_HIDDEN],
            gated: vec![0.0; EMBED],
            input: vec![0.0; CODE + FEATURES.len()],
            anchor: [0.0; 6],
            scale: 1.0,
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

    /// Encodes `map` (`MAP_SIZE x MAP_SIZE`, from [`map_features`]): what the following predictions attend to.
    ///
    /// # Panics
    /// If `map` is shorter than a map.
    pub fn embed(&mut self, map: &[f32]) {
        conv_relu(&self.conv1, CONV1, 1, MAP_SIZE, map, &mut self.a1);
        conv_relu(
            &self.conv2,
            CONV2,
            CONV1.0,
            SIDE1,
            &self.a1,
            &mut self.embed,
        );
    }

    /// Every member's scaled outputs (`members x 7` into `out`) for one sample's vector features and its offset
    /// from the embedded map's anchor.
    ///
    /// # Panics
    /// If `out` is shorter than `members x 7`.
    pub fn predict(
        &mut self,
        vector: &[f32; FEATURES.len()],
        offset: &[f32; OFFSETS.len()],
        out: &mut [f32],
    ) {
        dense(&self.gate1, offset, &mut self.g1, false);
        self.g1.iter_mut().for_each(|v| *v = sigmoid(*v));
        dense(&self.gate2, &self.g1, &mut self.gated, false);
        for (g, e) in self.gated.iter_mut().zip(&self.embed) {
            *g = sigmoid(*g) * e;
        }
        let (code, vec_in) = self.input.split_at_mut(CODE);
        dense(&self.fuse, &self.gated, code, false);
        code.iter_mut().for_each(|v| *v = v.max(0.0));
        vec_in.copy_from_slice(vector);
        self.heads.run(&self.input, out);
    }

    /// Takes the map at `anchor` from `world` and encodes it: the pose later predictions are offset from.
    pub fn set_anchor(&mut self, world: &World, anchor: &Pose, scale: f64) {
        let mut map = std::mem::take(&mut self.map);
        map_features(world, anchor, scale, &mut map);
        self.embed(&map);
        self.map = map;
        self.anchor = *anchor;
        self.scale = scale;
    }

    /// [`predict`](Self::predict) for a vehicle at `pose` over the current anchor's map.
    pub fn predict_at(&mut self, pose: &Pose, vector: &[f32; FEATURES.len()], out: &mut [f32]) {
        let offset = offset_features(&self.anchor, pose, self.scale);
        self.predict(vector, &offset, out);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_offset_is_taken_in_the_anchors_heading_frame() {
        // Anchor heading +y; the pose 4 m further along +y and 2 m towards -x, turned by 90 degrees.
        let anchor = [1.0, 1.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2];
        let pose = [-1.0, 5.0, 1.0, 0.0, 0.0, std::f64::consts::PI];
        let o = offset_features(&anchor, &pose, 1.0);
        let want = [0.5, 0.25, 0.5, 1.0, 0.0];
        for (a, b) in o.iter().zip(want) {
            assert!((a - b).abs() < 1e-6, "{o:?}");
        }
    }
}
