//! The vehicle's controls ([`Action`], checked by [`Action::validate`]) and what it reports to whoever drives it:
//! its ground-truth state ([`VehicleState`]) and the facts about it a driver may use ([`VehicleInfo`]). They live
//! with the vehicle, which every layer above (planners, episodes, services) uses; `crate::planner` re-exports them.

use serde::{Deserialize, Serialize};

/// A driving command. Ranges are checked by the episode runner: a NaN or out-of-range action fails the episode
/// with reason `invalid_action`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Action {
    /// Normalised steering in [-1, 1]; +1 is full left (counter-clockwise about +z).
    pub steering: f64,
    /// Normalised drive command in [-1, 1]; negative drives in reverse.
    pub throttle: f64,
    /// Normalised brake in [0, 1].
    pub brake: f64,
}

impl Action {
    /// Why this action is not acceptable, if it is not.
    pub fn validate(&self) -> Result<(), String> {
        let check = |name: &str, v: f64, lo: f64, hi: f64| {
            if !v.is_finite() {
                Err(format!("{name} is not finite ({v})"))
            } else if v < lo || v > hi {
                Err(format!("{name} = {v} is outside [{lo}, {hi}]"))
            } else {
                Ok(())
            }
        };
        check("steering", self.steering, -1.0, 1.0)?;
        check("throttle", self.throttle, -1.0, 1.0)?;
        check("brake", self.brake, 0.0, 1.0)
    }
}

/// Ground-truth state of the vehicle, as a real system with perfect state estimation would know it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct VehicleState {
    /// Simulated time since the start of the episode, s.
    pub time: f64,
    /// Chassis reference point in the world frame, m.
    pub position: [f64; 3],
    /// Cardan angles (roll about x, pitch about y, yaw about z), rad.
    pub roll: f64,
    pub pitch: f64,
    pub yaw: f64,
    /// Linear velocity in the world frame, m/s.
    pub velocity: [f64; 3],
    /// Angular velocity in the chassis frame, rad/s.
    pub angular_velocity: [f64; 3],
    /// Signed forward speed along the chassis x axis, m/s.
    pub speed: f64,
    /// Steering currently applied (after rate limits), normalised [-1, 1].
    pub steering: f64,
}

/// Facts about the vehicle a planner may use (geometry, limits), at the episode's scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VehicleInfo {
    pub name: String,
    /// Scale of the vehicle relative to its full-size original (1, 1/6, 1/10).
    pub scale: f64,
    pub wheelbase: f64,
    pub track: f64,
    /// Overall footprint, m.
    pub length: f64,
    pub width: f64,
    /// Largest road-wheel steering angle (0 for skid-steered vehicles), rad.
    pub max_steer: f64,
    /// Whether the vehicle turns by differential (skid) steering.
    pub skid_steer: bool,
    /// Nominal cruising speed for the benchmark (scaled), m/s.
    pub nominal_speed: f64,
    /// Top speed, m/s.
    pub max_speed: f64,
}
