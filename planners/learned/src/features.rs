//! The policies' inputs (layout [`LAYOUT`]): one definition, used by the Rust built-in planners and, through the
//! Python extension, by training, so a trained policy sees the same numbers in both places.
//!
//! A policy observes
//! - a vector of [`FEATURES`] (`f32`), made by [`vector_features`] from the SDK's `state` and `goal` vectors
//!   ([`sim_core::observe::state_vector`], [`sim_core::observe::goal_vector`]) and the throttle it last commanded;
//! - a crop of [`CROP_CHANNELS`] x [`CROP_SIZE`] x [`CROP_SIZE`] (`f32`), made by [`crop_features`] from the SDK's
//!   heading-aligned crops of [`CROP_SIZE`] cells of `scale x` [`CROP_CELL_PER_SCALE`] m centred on the vehicle
//!   ([`sim_core::observe::relative_elevation_crop`], [`sim_core::observe::obstacle_crop`]).
//!
//! Every entry is scaled to order one by the vehicle's scale and nominal speed and clipped to
//! `[-`[`CLIP`]`, `[`CLIP`]`]`, so no running normaliser has to travel with the weights.

/// Version of the observation layout and network shape; a weights file records it.
pub const LAYOUT: &str = "vertibench-policy-v1";

/// Names of the vector features, in order.
pub const FEATURES: [&str; 12] = [
    "goal_cos",      // goal bearing in the heading frame: cos
    "goal_sin",      // and sin (left positive)
    "goal_distance", // horizontal distance / (50 m x scale), at most CLIP
    "speed",         // signed forward speed / nominal speed
    "lateral_speed", // velocity to the left of the heading / nominal speed
    "roll",          // rad / 0.5
    "pitch",         // rad / 0.5
    "wx",            // chassis-frame angular velocity, rad/s
    "wy",
    "wz",
    "steering",   // applied steering, normalised
    "throttle_1", // the throttle the policy commanded at the previous step (0 at the start)
];

/// Crop cells per side.
pub const CROP_SIZE: usize = 16;
/// Metres per crop cell for a vehicle of scale 1 (cells are `scale x` this).
pub const CROP_CELL_PER_SCALE: f64 = 1.0;
/// Crop channels: elevation relative to the vehicle / (2 m x scale), obstacles (1 = occupied or off the map).
pub const CROP_CHANNELS: usize = 2;
/// Every feature lies in `[-CLIP, CLIP]`.
pub const CLIP: f32 = 5.0;

/// What the features are scaled by: the vehicle's scale and nominal speed ([`sim_core::planner::VehicleInfo`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scales {
    pub scale: f64,
    pub nominal_speed: f64,
}

/// `v` clamped to `[-CLIP, CLIP]`, NaN to 0.
pub(crate) fn clip(v: f64) -> f32 {
    let c = f64::from(CLIP);
    if v.is_nan() {
        0.0
    } else {
        v.clamp(-c, c) as f32
    }
}

/// The vector features from the SDK's `state` (15 entries), `goal` (3 entries) and the throttle last commanded.
pub fn vector_features(
    state: &[f64; 15],
    goal: &[f64; 3],
    last_throttle: f64,
    k: &Scales,
) -> [f32; FEATURES.len()] {
    let [ahead, left, distance] = *goal;
    let d = distance.max(1e-9);
    let yaw = state[5];
    let (s, c) = yaw.sin_cos();
    let (vx, vy) = (state[6], state[7]);
    let v = k.nominal_speed.max(1e-9);
    [
        clip(ahead / d),
        clip(left / d),
        clip(distance / (50.0 * k.scale)),
        clip(state[12] / v),
        clip((-s * vx + c * vy) / v),
        clip(state[3] / 0.5),
        clip(state[4] / 0.5),
        clip(state[9]),
        clip(state[10]),
        clip(state[11]),
        clip(state[13]),
        clip(last_throttle),
    ]
}

/// The crop features (`CROP_CHANNELS x CROP_SIZE x CROP_SIZE`, channel-major as a CNN reads them) from the SDK's
/// relative elevation crop and obstacle crop (`CROP_SIZE x CROP_SIZE` each, row 0 ahead, column 0 left).
///
/// # Panics
/// If a crop has fewer than `CROP_SIZE^2` cells or `out` fewer than `CROP_CHANNELS x CROP_SIZE^2`.
pub fn crop_features(elevation: &[f32], obstacles: &[u8], scale: f64, out: &mut [f32]) {
    let n = CROP_SIZE * CROP_SIZE;
    let (e, o) = out[..CROP_CHANNELS * n].split_at_mut(n);
    let per = 1.0 / (2.0 * scale);
    for (dst, h) in e.iter_mut().zip(&elevation[..n]) {
        *dst = clip(f64::from(*h) * per);
    }
    for (dst, occ) in o.iter_mut().zip(&obstacles[..n]) {
        *dst = f32::from(*occ.min(&1));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const K: Scales = Scales {
        scale: 1.0,
        nominal_speed: 4.0,
    };

    fn state(yaw: f64, v: [f64; 2]) -> [f64; 15] {
        let mut s = [0.0; 15];
        s[5] = yaw;
        s[6] = v[0];
        s[7] = v[1];
        s[12] = 2.0;
        s[3] = 0.1;
        s[13] = -0.5;
        s
    }

    #[test]
    fn the_goal_is_a_bearing_and_a_scaled_distance() {
        let f = vector_features(&state(0.0, [2.0, 0.0]), &[30.0, 40.0, 50.0], 0.3, &K);
        assert_eq!(&f[..3], &[0.6, 0.8, 1.0]);
        assert_eq!(f[3], 0.5);
        assert_eq!(f[5], 0.2);
        assert_eq!(f[10], -0.5);
        assert_eq!(f[11], 0.3);
        // At the goal the bearing is zero, not NaN.
        let at = vector_features(&state(0.0, [0.0; 2]), &[0.0, 0.0, 0.0], 0.0, &K);
        assert!(at.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn lateral_speed_is_in_the_heading_frame() {
        // Heading +y, moving +x in the world: to the vehicle's right.
        let f = vector_features(
            &state(std::f64::consts::FRAC_PI_2, [4.0, 0.0]),
            &[1.0, 0.0, 1.0],
            0.0,
            &K,
        );
        assert!((f[4] + 1.0).abs() < 1e-6, "{}", f[4]);
    }

    #[test]
    fn features_are_clipped_and_nan_free() {
        let mut s = state(0.0, [0.0; 2]);
        s[11] = 100.0;
        s[9] = f64::NAN;
        let f = vector_features(&s, &[1e6, 0.0, 1e6], 0.0, &K);
        assert_eq!(f[9], CLIP);
        assert_eq!(f[7], 0.0);
        assert_eq!(f[2], CLIP);
    }

    #[test]
    fn crops_are_scaled_channel_major() {
        let n = CROP_SIZE * CROP_SIZE;
        let mut elevation = vec![0.0f32; n];
        elevation[1] = 1.0;
        elevation[2] = -100.0;
        let mut obstacles = vec![0u8; n];
        obstacles[3] = 1;
        let mut out = vec![9.0f32; CROP_CHANNELS * n];
        crop_features(&elevation, &obstacles, 0.5, &mut out);
        assert_eq!(out[1], 1.0);
        assert_eq!(out[2], -CLIP);
        assert_eq!(out[n + 3], 1.0);
        assert_eq!(out[n + 2], 0.0);
    }
}
