//! The kinodynamic models' inputs and outputs (layout [`LAYOUT`]): one definition, used by the Rust planners and,
//! through the Python extension, by training, so a trained model sees the same numbers in both places.
//!
//! A model predicts the vehicle's 6-DoF change of pose over one model step of [`STEP_FRAMES`] control periods
//! from
//! - a vector of [`FEATURES`] (`f32`, [`vector_features`]): the previous step's change of pose, roll, pitch, the
//!   applied steering, the action held over the step and the ground under the vehicle;
//! - an elevation crop of [`CROP_SIZE`] x [`CROP_SIZE`] cells of `scale x` [`CROP_CELL_PER_SCALE`] m
//!   ([`crop_features`]), heading-aligned and centred [`CROP_AHEAD_PER_SCALE`] m (scaled) ahead of the vehicle, so
//!   it covers the ground under the vehicle and ahead of it; heights relative to the vehicle's.
//!
//! Changes of pose ([`pose_delta`]) are taken in the frame of the heading at the step's start: forward, left, up
//! (m), roll, pitch, yaw (rad, wrapped). Every entry is scaled to order one by fixed factors of the vehicle's scale
//! and nominal speed ([`Scales`]) and clipped to `[-`[`CLIP`]`, `[`CLIP`]`]`; the targets ([`TARGETS`]) use the
//! same factors, so no normaliser travels with the weights.

use sim_core::observe::{relative_elevation_crop, CropSpec};
use sim_core::planner::VehicleState;
use sim_core::world::{Surface, World};

/// Version of the input/output layout and network shape; a weights file records it.
pub const LAYOUT: &str = "vertibench-kino-v1";
/// Control periods per model step (at the evaluation's 20 Hz control rate: 0.25 s nominal).
pub const STEP_FRAMES: usize = 5;
/// The model step in nominal seconds (what changes of pose are scaled by, with the nominal speed).
pub const STEP_S: f64 = STEP_FRAMES as f64 / 20.0;
/// Radians a change of attitude is divided by.
const ANGLE_STEP: f64 = 0.1;

/// A pose: x, y, z (m), roll, pitch, yaw (rad).
pub type Pose = [f64; 6];

/// Names of the vector features, in order.
pub const FEATURES: [&str; 16] = [
    "prev_forward", // previous step's change of pose in the current heading frame, / (nominal speed x STEP_S)
    "prev_left",
    "prev_up",
    "prev_roll", // / 0.1 rad
    "prev_pitch",
    "prev_yaw",
    "roll",            // rad / 0.5
    "pitch",           // rad / 0.5
    "steering",        // applied steering at the step's start, normalised
    "action_steering", // command held over the step
    "action_throttle",
    "action_brake",
    "friction", // rigid ground's friction coefficient under the vehicle (0 on soil)
    "mud",      // 1 on that soil
    "sand",
    "snow",
];
/// Names of the outputs, in order: the change of pose over the step (scaled as the `prev_*` features) and the
/// applied steering at its end.
pub const TARGETS: [&str; 7] = ["forward", "left", "up", "roll", "pitch", "yaw", "steering"];
/// Crop cells per side.
pub const CROP_SIZE: usize = 16;
/// Metres per crop cell for a vehicle of scale 1.
pub const CROP_CELL_PER_SCALE: f64 = 0.5;
/// How far ahead of the vehicle the crop is centred, m for a vehicle of scale 1.
pub const CROP_AHEAD_PER_SCALE: f64 = 2.0;
/// Elevations are divided by this many metres (times the scale).
const ELEVATION_M: f64 = 2.0;
use crate::features::clip;
/// Every feature lies in `[-CLIP, CLIP]` (the policies' bound).
pub use crate::features::CLIP;

/// What the features are scaled by: the vehicle's scale and nominal speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scales {
    pub scale: f64,
    pub nominal_speed: f64,
}

impl Scales {
    /// The factors of the seven targets: metres for the position (nominal distance per step), radians for the
    /// attitude, one for the steering.
    pub fn target_factors(&self) -> [f64; 7] {
        let d = (self.nominal_speed * STEP_S).max(1e-9);
        [d, d, d, ANGLE_STEP, ANGLE_STEP, ANGLE_STEP, 1.0]
    }
}

fn wrap(a: f64) -> f64 {
    a.sin().atan2(a.cos())
}

/// The change from pose `from` to pose `to` in the frame of `from`'s heading: forward, left, up, and the wrapped
/// changes of roll, pitch and yaw.
pub fn pose_delta(from: &Pose, to: &Pose) -> [f64; 6] {
    let (s, c) = from[5].sin_cos();
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    [
        c * dx + s * dy,
        -s * dx + c * dy,
        to[2] - from[2],
        wrap(to[3] - from[3]),
        wrap(to[4] - from[4]),
        wrap(to[5] - from[5]),
    ]
}

/// The pose reached from `from` by a change `delta` taken in `from`'s heading frame (the inverse of
/// [`pose_delta`], yaw wrapped).
pub fn apply_delta(from: &Pose, delta: &[f64; 6]) -> Pose {
    let (s, c) = from[5].sin_cos();
    [
        from[0] + c * delta[0] - s * delta[1],
        from[1] + s * delta[0] + c * delta[1],
        from[2] + delta[2],
        from[3] + delta[3],
        from[4] + delta[4],
        wrap(from[5] + delta[5]),
    ]
}

/// The ground under `(x, y)`: rigid friction coefficient (0 on soil), and one flag each for mud, sand and snow
/// (all 0 off the map or on rigid ground).
pub fn ground(world: &World, x: f64, y: f64) -> [f64; 4] {
    if !world.heightmap.contains(x, y) {
        return [0.0; 4];
    }
    let patch = world.patch_at(x, y);
    match patch.surface {
        Surface::Rigid { friction } => [friction, 0.0, 0.0, 0.0],
        Surface::Deformable { .. } => {
            use sim_core::world::Semantic::{Mud, Sand, Snow};
            let flag = |s| if patch.semantic == s { 1.0 } else { 0.0 };
            [0.0, flag(Mud), flag(Sand), flag(Snow)]
        }
    }
}

/// The vector features: `prev` is the previous step's [`pose_delta`] from the pose one step ago to the current
/// pose `now`, taken in the current heading frame (zero at an episode's start); `steering` the applied steering;
/// `action` (steering, throttle, brake) held over the step; `ground` from [`ground`].
pub fn vector_features(
    prev: &[f64; 6],
    now: &Pose,
    steering: f64,
    action: &[f64; 3],
    ground: &[f64; 4],
    k: &Scales,
) -> [f32; FEATURES.len()] {
    let f = k.target_factors();
    let mut out = [0.0f32; FEATURES.len()];
    for i in 0..6 {
        out[i] = clip(prev[i] / f[i]);
    }
    out[6] = clip(now[3] / 0.5);
    out[7] = clip(now[4] / 0.5);
    out[8] = clip(steering);
    for i in 0..3 {
        out[9 + i] = clip(action[i]);
    }
    for i in 0..4 {
        out[12 + i] = clip(ground[i]);
    }
    out
}

/// The previous step's change of pose in the current heading frame (what `prev` of [`vector_features`] is): the
/// displacement from `before` to `now` rotated into `now`'s heading frame, and the attitude changes.
pub fn previous_delta(before: &Pose, now: &Pose) -> [f64; 6] {
    let d = pose_delta(before, now);
    let turn = d[5];
    let (s, c) = turn.sin_cos();
    // `pose_delta` is in `before`'s frame; rotate the horizontal part by the turn into `now`'s.
    [
        c * d[0] + s * d[1],
        -s * d[0] + c * d[1],
        d[2],
        d[3],
        d[4],
        d[5],
    ]
}

/// The elevation crop for a vehicle at `pose` (`CROP_SIZE x CROP_SIZE` into `out`, row 0 ahead, column 0 left),
/// relative to the pose's height and divided by 2 m x scale.
///
/// # Panics
/// If `out` holds fewer than `CROP_SIZE^2` entries.
pub fn crop_features(world: &World, pose: &Pose, scale: f64, out: &mut [f32]) {
    heading_crop(
        world,
        pose,
        scale,
        (CROP_SIZE, CROP_CELL_PER_SCALE, CROP_AHEAD_PER_SCALE),
        out,
    );
}

/// A heading-aligned elevation crop of `size x size` cells of `cell` m x scale, centred `ahead` m x scale ahead
/// of `pose`, relative to the pose's height, divided by 2 m x scale and clipped (row 0 ahead, column 0 left).
pub(crate) fn heading_crop(
    world: &World,
    pose: &Pose,
    scale: f64,
    (size, cell, ahead): (usize, f64, f64),
    out: &mut [f32],
) {
    let ahead = ahead * scale;
    let (s, c) = pose[5].sin_cos();
    let state = VehicleState {
        position: [pose[0] + c * ahead, pose[1] + s * ahead, pose[2]],
        yaw: pose[5],
        ..VehicleState::default()
    };
    let spec = CropSpec {
        size,
        resolution: cell * scale,
    };
    relative_elevation_crop(world, &state, &spec, out);
    let m = (ELEVATION_M * scale) as f32;
    for v in out.iter_mut().take(size * size) {
        let h = f64::from(*v / m);
        *v = clip(h);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_delta_applied_returns_the_pose_it_was_taken_to() {
        let from = [3.0, -2.0, 1.0, 0.1, -0.05, 3.0];
        let to = [4.0, -1.5, 1.2, 0.12, -0.02, -3.1];
        let d = pose_delta(&from, &to);
        let back = apply_delta(&from, &d);
        for i in 0..6 {
            let e = if i == 5 {
                wrap(back[i] - to[i])
            } else {
                back[i] - to[i]
            };
            assert!(e.abs() < 1e-12, "{i}: {back:?} vs {to:?}");
        }
        // Heading 3.0 rad, moving to the lower right in the world: mostly backwards in the vehicle's frame.
        assert!(d[0] < 0.0);
        assert!(
            (d[5] - wrap(-3.1 - 3.0)).abs() < 1e-12,
            "yaw wraps across pi"
        );
    }

    #[test]
    fn the_previous_delta_is_in_the_current_heading_frame() {
        // Driving 1 m along +x while turning from 0 to 90 degrees: in the new heading frame that was 1 m to the
        // right (negative left).
        let d = previous_delta(
            &[0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
            &[1.0, 0.0, 0.0, 0.0, 0.0, std::f64::consts::FRAC_PI_2],
        );
        assert!(d[0].abs() < 1e-12 && (d[1] + 1.0).abs() < 1e-12, "{d:?}");
    }
}
