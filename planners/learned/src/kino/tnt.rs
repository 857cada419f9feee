//! [`TravNet`]: TNT's traversability estimator (`tnt`, layout [`TNT_LAYOUT`], `KINO.md`), after Pan, Datar, Pokhrel
//! et al. (arXiv 2409.17479) and the release's `systems/TNT`: a map-to-map network from the terrain-attentive
//! model's map at a decision's pose to a 16 x 16 grid of 1 m cells over the same square, with 5 channels in [0, 1]
//! ([`CHANNELS`]) for each of 4 headings relative to the map's. The planner `tnt` estimates the grid once per
//! decision and charges each rollout step the channels at its pose ([`TravNet::cost`]), the pose transformed into
//! the map's frame ([`grid_index`]): the release indexed its vehicle-centred map with world coordinates.

use super::features::Pose;
use super::tal::{map_features, MAP_META, MAP_SIZE};
use crate::net::WeightsError;
use crate::nn::{conv_padded, expect_metadata, layer, open, sha256_hex, shape, ConvShape, Layer};
use sim_core::world::World;
use std::collections::BTreeMap;

/// Version of the estimator's inputs, outputs and network shape.
pub const TNT_LAYOUT: &str = "vertibench-tnt-v1";
/// The channels of every cell and heading (`KINO.md`).
pub const CHANNELS: [&str; 5] = ["roll", "pitch", "slip", "stuck", "rollover"];
/// Headings relative to the map's: ahead, left, back, right.
pub const HEADINGS: usize = 4;
/// Grid cells per side, and what a weights file's `grid` metadata must say.
pub const GRID: usize = 16;
pub const GRID_META: &str = "16x16";
/// Grid cell side, how far ahead of the anchor row 0 starts and how far left column 0 starts (m at scale 1).
const CELL_PER_SCALE: f64 = 1.0;
const AHEAD_PER_SCALE: f64 = 13.0;
const HALF_WIDTH_PER_SCALE: f64 = 8.0;
/// The weights of the channels in the cost's weighted mean (summing to 1), the unlikely events weighing most: the
/// release sums 10 of its 14 channels with weights of 0.1 to 0.3.
pub const CHANNEL_WEIGHTS: [f64; 5] = [0.15, 0.15, 0.2, 0.2, 0.3];

const CONV1: ConvShape = ConvShape {
    filters: 8,
    k: 3,
    stride: 1,
    pad: 1,
    dilation: 1,
};
const OUTPUTS: usize = HEADINGS * CHANNELS.len();

/// Index `(heading * GRID + row) * GRID + col` of `pose` in the grid of the map taken at `anchor`, or `None` off
/// the grid: the pose's offset in the anchor's heading frame, row 0 the farthest ahead, column 0 the farthest left,
/// the change of yaw rounded to a quarter turn (0 ahead, 1 left, 2 back, 3 right; ties to even, as NumPy rounds).
pub fn grid_index(anchor: &Pose, pose: &Pose, scale: f64) -> Option<usize> {
    let (dx, dy) = (pose[0] - anchor[0], pose[1] - anchor[1]);
    let (s, c) = anchor[5].sin_cos();
    let (fwd, left) = (c * dx + s * dy, -s * dx + c * dy);
    let row = ((AHEAD_PER_SCALE * scale - fwd) / (CELL_PER_SCALE * scale)).floor();
    let col = ((HALF_WIDTH_PER_SCALE * scale - left) / (CELL_PER_SCALE * scale)).floor();
    let inside = |v: f64| (0.0..GRID as f64).contains(&v);
    if !(inside(row) && inside(col)) {
        return None;
    }
    let dyaw = (pose[5] - anchor[5])
        .sin()
        .atan2((pose[5] - anchor[5]).cos());
    let heading = (dyaw / std::f64::consts::FRAC_PI_2).round_ties_even() as i64;
    let heading = heading.rem_euclid(HEADINGS as i64) as usize;
    Some((heading * GRID + row as usize) * GRID + col as usize)
}

/// A `vertibench-tnt-v1` weights file with its scratch buffers (an estimate allocates nothing) and the grid of the
/// current anchor.
#[derive(Clone, Debug)]
pub struct TravNet {
    conv1: Layer,
    conv2: Layer,
    conv3: Layer,
    out: Layer,
    width: usize,
    metadata: BTreeMap<String, String>,
    sha256: String,
    map: Vec<f32>,
    a1: Vec<f32>,
    a2: Vec<f32>,
    a3: Vec<f32>,
    /// `[HEADINGS, CHANNELS, GRID, GRID]`, in [0, 1].
    grid: Vec<f32>,
    anchor: Pose,
    scale: f64,
}

impl TravNet {
    /// Reads a weights file's bytes, checking its layout, metadata and every tensor's dtype and shape.
    pub fn from_bytes(bytes: &[u8]) -> Result<TravNet, WeightsError> {
        let (metadata, st) = open(bytes)?;
        let (channels, headings) = (CHANNELS.join(","), HEADINGS.to_string());
        expect_metadata(
            &metadata,
            &[
                ("format", TNT_LAYOUT),
                ("channels", channels.as_str()),
                ("headings", headings.as_str()),
                ("grid", GRID_META),
                ("map", MAP_META),
            ],
        )?;
        let width = shape(&st, "conv2.weight")?.first().copied().unwrap_or(0);
        if !(1..=256).contains(&width) {
            return Err(WeightsError::Tensor {
                name: "conv2.weight",
                problem: format!("{width} filters, expected 1 to 256"),
            });
        }
        let l = |w, b, s: &[usize]| layer(&st, (w, b), s);
        let c1 = CONV1.filters;
        Ok(TravNet {
            conv1: l("conv1.weight", "conv1.bias", &[c1, 1, 3, 3])?,
            conv2: l("conv2.weight", "conv2.bias", &[width, c1, 3, 3])?,
            conv3: l("conv3.weight", "conv3.bias", &[width, width, 3, 3])?,
            out: l("out.weight", "out.bias", &[OUTPUTS, width, 1, 1])?,
            width,
            metadata,
            sha256: sha256_hex(bytes),
            map: vec![0.0; MAP_SIZE * MAP_SIZE],
            a1: vec![0.0; c1 * MAP_SIZE * MAP_SIZE],
            a2: vec![0.0; width * GRID * GRID],
            a3: vec![0.0; width * GRID * GRID],
            grid: vec![0.0; OUTPUTS * GRID * GRID],
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

    /// Estimates the grid of `map` (`MAP_SIZE x MAP_SIZE`, from [`map_features`]) into [`TravNet::grid`].
    ///
    /// # Panics
    /// If `map` is shorter than a map.
    pub fn estimate(&mut self, map: &[f32]) {
        let w = self.width;
        let conv = |filters, stride, pad, dilation| ConvShape {
            filters,
            k: 3,
            stride,
            pad,
            dilation,
        };
        conv_padded(&self.conv1, CONV1, 1, MAP_SIZE, map, &mut self.a1, true);
        let (c2, c3) = (conv(w, 2, 1, 1), conv(w, 1, 2, 2));
        conv_padded(
            &self.conv2,
            c2,
            CONV1.filters,
            MAP_SIZE,
            &self.a1,
            &mut self.a2,
            true,
        );
        conv_padded(&self.conv3, c3, w, GRID, &self.a2, &mut self.a3, true);
        let one = ConvShape {
            filters: OUTPUTS,
            k: 1,
            stride: 1,
            pad: 0,
            dilation: 1,
        };
        conv_padded(&self.out, one, w, GRID, &self.a3, &mut self.grid, false);
        self.grid
            .iter_mut()
            .for_each(|v| *v = 1.0 / (1.0 + (-*v).exp()));
    }

    /// The last estimate: `[HEADINGS, CHANNELS, GRID, GRID]`, in [0, 1].
    pub fn grid(&self) -> &[f32] {
        &self.grid
    }

    /// Takes the map at `anchor` from `world` and estimates its grid: the frame later queries are made in.
    pub fn set_anchor(&mut self, world: &World, anchor: &Pose, scale: f64) {
        let mut map = std::mem::take(&mut self.map);
        map_features(world, anchor, scale, &mut map);
        self.estimate(&map);
        self.map = map;
        self.anchor = *anchor;
        self.scale = scale;
    }

    /// The channels at `pose` in the current anchor's grid, or `None` off the grid.
    pub fn at(&self, pose: &Pose) -> Option<[f32; CHANNELS.len()]> {
        let i = grid_index(&self.anchor, pose, self.scale)?;
        let (heading, cell) = (i / (GRID * GRID), i % (GRID * GRID));
        Some(std::array::from_fn(|c| {
            self.grid[(heading * CHANNELS.len() + c) * GRID * GRID + cell]
        }))
    }

    /// The weighted mean of the channels at `pose` ([`CHANNEL_WEIGHTS`]), 0 off the grid (nothing known there).
    pub fn cost(&self, pose: &Pose) -> f64 {
        self.at(pose).map_or(0.0, |v| {
            v.iter()
                .zip(CHANNEL_WEIGHTS)
                .map(|(&x, w)| f64::from(x) * w)
                .sum()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_lands_in_the_cell_and_heading_of_the_anchors_frame() {
        // Anchor at (10, 20) heading +y (as the Python test of `trav.grid_index`).
        let anchor = [10.0, 20.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2];
        let ahead = [9.5, 25.5, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2];
        let left = [7.5, 20.5, 0.0, 0.0, 0.0, std::f64::consts::PI];
        let behind = [10.0, 16.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2];
        assert_eq!(grid_index(&anchor, &ahead, 1.0), Some(7 * 16 + 7));
        assert_eq!(grid_index(&anchor, &left, 1.0), Some(256 + 12 * 16 + 5));
        assert_eq!(grid_index(&anchor, &behind, 1.0), None);
        // At scale 1/10 the same poses, scaled about the anchor, land in the same cells.
        let s = |p: [f64; 6]| {
            let mut q = p;
            q[0] = anchor[0] + 0.1 * (p[0] - anchor[0]);
            q[1] = anchor[1] + 0.1 * (p[1] - anchor[1]);
            q
        };
        assert_eq!(grid_index(&anchor, &s(ahead), 0.1), Some(7 * 16 + 7));
        assert_eq!(grid_index(&anchor, &s(left), 0.1), Some(256 + 12 * 16 + 5));
    }
}
