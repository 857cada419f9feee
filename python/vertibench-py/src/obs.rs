//! The environments' observation: the vehicle's state and the goal as vectors, and heading-aligned map crops
//! (sim-core's `observe`, the same crops the planner protocol sends), written into per-environment buffers.

use sim_core::observe::{elevation_crop, obstacle_crop, semantics_crop, CropSpec};
use sim_core::planner::VehicleState;
use sim_core::world::World;

/// Names of the `state` vector's entries, in order (world frame, SI units, angles in rad).
pub const STATE_FIELDS: [&str; 15] = [
    "x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "wx", "wy", "wz", "speed", "steering",
    "time",
];
/// Names of the `goal` vector's entries: the goal in the vehicle's heading frame (m ahead, m to the left) and its
/// horizontal distance (m).
pub const GOAL_FIELDS: [&str; 3] = ["ahead", "left", "distance"];

/// One environment's observation.
#[derive(Clone, Debug)]
pub struct ObsBuf {
    pub state: [f64; STATE_FIELDS.len()],
    pub goal: [f64; GOAL_FIELDS.len()],
    /// Elevation relative to the chassis reference point's height, m (`size * size`, row 0 ahead, column 0 left).
    pub elevation: Vec<f32>,
    pub semantics: Vec<u8>,
    pub obstacles: Vec<u8>,
}

impl ObsBuf {
    pub fn new(crop: Option<&CropSpec>) -> ObsBuf {
        let n = crop.map_or(0, |c| c.size * c.size);
        ObsBuf {
            state: [0.0; STATE_FIELDS.len()],
            goal: [0.0; GOAL_FIELDS.len()],
            elevation: vec![0.0; n],
            semantics: vec![0; n],
            obstacles: vec![0; n],
        }
    }

    /// Writes the observation of `s` on `world` with the goal at `goal`.
    pub fn write(
        &mut self,
        s: &VehicleState,
        world: &World,
        goal: [f64; 2],
        crop: Option<&CropSpec>,
    ) {
        let [x, y, z] = s.position;
        let [vx, vy, vz] = s.velocity;
        let [wx, wy, wz] = s.angular_velocity;
        self.state = [
            x, y, z, s.roll, s.pitch, s.yaw, vx, vy, vz, wx, wy, wz, s.speed, s.steering, s.time,
        ];
        let (dx, dy) = (goal[0] - x, goal[1] - y);
        let (sn, c) = s.yaw.sin_cos();
        self.goal = [c * dx + sn * dy, -sn * dx + c * dy, dx.hypot(dy)];
        if let Some(spec) = crop {
            elevation_crop(world, s, spec, &mut self.elevation);
            let z = z as f32;
            self.elevation.iter_mut().for_each(|h| *h -= z);
            semantics_crop(world, s, spec, &mut self.semantics);
            obstacle_crop(world, s, spec, &mut self.obstacles);
        }
    }

    pub fn copy_from(&mut self, o: &ObsBuf) {
        self.state = o.state;
        self.goal = o.goal;
        self.elevation.copy_from_slice(&o.elevation);
        self.semantics.copy_from_slice(&o.semantics);
        self.obstacles.copy_from_slice(&o.obstacles);
    }
}
