//! Whether a vehicle can move off from a task's start at all: the datasheet's move-off share (issue 29). From the
//! start pose (facing the goal, settled at rest, as an episode begins), full throttle for 20 s (times
//! sqrt(scale)) with the steering holding the bearing to the goal; the vehicle moved off if it ends at least 5 m
//! (times scale) from where it started. The share of starts it fails on is what a planner that heads for the goal
//! cannot leave, set by the vehicle and the terrain alone (sim-core r6 left 91 of the release's 1000 original tasks
//! stuck at their start for every planner); a planner that steers elsewhere first may leave some of them.

use crate::characterize::{act, drive, sim_at, steer};
use crate::episode_run::start_pose;
use crate::vehicle::VehicleSpec;
use crate::world::{Task, World};
use std::f64::consts::{PI, TAU};

/// Distance from its start, m at full scale, below which a vehicle did not move off.
pub const MOVE_OFF_DISTANCE: f64 = 5.0;
/// How long it tries, s at full scale.
pub const MOVE_OFF_TIME: f64 = 20.0;

/// How far the vehicle gets from `task`'s start in [`MOVE_OFF_TIME`] at full throttle towards the goal, m.
/// `dt`: the physics step (default: the vehicle's).
pub fn move_off_distance(world: &World, task: &Task, spec: &VehicleSpec, dt: Option<f64>) -> f64 {
    let (x0, y0, yaw) = start_pose(task);
    let mut sim = sim_at(world, spec, dt, x0, y0, yaw);
    let start = sim.position();
    drive(&mut sim, MOVE_OFF_TIME, |sim| {
        let s = sim.state();
        let bearing = (task.goal[1] - s.position[1]).atan2(task.goal[0] - s.position[0]);
        act(
            steer(sim, (bearing - s.yaw + PI).rem_euclid(TAU) - PI),
            1.0,
            0.0,
        )
    });
    (sim.position() - start).xy().norm()
}

/// Whether the vehicle moves off from `task`'s start ([`move_off_distance`] at least [`MOVE_OFF_DISTANCE`] times
/// the vehicle's scale).
pub fn moves_off(world: &World, task: &Task, spec: &VehicleSpec, dt: Option<f64>) -> bool {
    move_off_distance(world, task, spec, dt) >= MOVE_OFF_DISTANCE * spec.scale
}
