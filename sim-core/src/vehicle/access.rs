//! Reading and writing a [`Simulation`]: accessors, the wheels' reports, the ground-truth [`VehicleState`] and
//! overwriting the chassis with an observation. (The whole dynamic state is read and set in `dynamics.rs`.)

use super::action::VehicleState;
use super::simulation::*;
use super::tyre::slip_velocity;
use crate::soil::SoilGrid;
use crate::vehicle::spec::VehicleSpec;
use crate::world::World;
use nalgebra::{UnitQuaternion, Vector3};
use std::sync::Arc;

impl Simulation {
    /// Physics time step, s.
    pub fn dt(&self) -> f64 {
        self.params.dt
    }

    pub fn spec(&self) -> &VehicleSpec {
        &self.params.spec
    }

    pub fn time(&self) -> f64 {
        self.state.time
    }

    pub fn position(&self) -> Vector3<f64> {
        self.state.pos
    }

    pub fn velocity(&self) -> Vector3<f64> {
        self.state.vel
    }

    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.state.rot
    }

    /// The world the vehicle drives in (shared with whoever built the simulation from the same `Arc`).
    pub fn world(&self) -> &Arc<World> {
        &self.world
    }

    /// Sets gravity (world frame, m/s^2): a tilt table turns it slowly instead of the ground.
    pub fn set_gravity(&mut self, g: Vector3<f64>) {
        self.gravity = g;
    }

    pub fn gravity(&self) -> Vector3<f64> {
        self.gravity
    }

    /// How long the vehicle took to settle when it was last placed ([`Simulation::settle`]), s.
    pub fn settle_time(&self) -> f64 {
        self.state.settle_time
    }

    /// Gear engaged (0 = first).
    pub fn gear(&self) -> usize {
        self.state.gear
    }

    /// What every wheel (track contact) did in the last step.
    pub fn wheels(&self) -> impl Iterator<Item = WheelReport> + '_ {
        let omega_w = self.state.rot * self.state.omega;
        self.params
            .wheels
            .iter()
            .zip(&self.state.wheels)
            .zip(&self.scratch.contacts)
            .zip(&self.scratch.ground_forces)
            .map(move |(((wp, w), c), f)| {
                // Inactive contacts are all zeros (no force, no sinkage).
                let slip = if c.active {
                    let (vsx, _) = slip_velocity(&self.state, c, w.spin, &omega_w);
                    let rim = w.spin * c.r_eff;
                    let den = rim.abs().max((vsx + rim).abs());
                    if den > 1e-9 {
                        -vsx / den
                    } else {
                        0.0
                    }
                } else {
                    0.0
                };
                WheelReport {
                    contact: c.active,
                    soil: c.soil,
                    sinkage: c.sinkage,
                    force: [f.x, f.y, f.z],
                    normal_load: f.dot(&c.normal),
                    slip,
                    left: wp.side > 0.0,
                    spin: w.spin,
                    compression: w.compression,
                    // Zero off soil and out of contact (the contact sets it only there).
                    soil_torque: c.soil_torque,
                }
            })
    }

    /// Spin rate of every wheel contact, rad/s.
    pub fn wheel_spins(&self) -> impl Iterator<Item = f64> + '_ {
        self.state.wheels.iter().map(|w| w.spin)
    }

    /// Suspension compression of every wheel from full droop, m.
    pub fn compressions(&self) -> impl Iterator<Item = f64> + '_ {
        self.state.wheels.iter().map(|w| w.compression)
    }

    /// Total kinetic energy (chassis translation and rotation, wheel spin), J.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.params.total_mass * self.state.vel.norm_squared()
            + 0.5
                * self
                    .state
                    .omega
                    .dot(&(self.params.inertia * self.state.omega))
            + self
                .state
                .wheels
                .iter()
                .map(|w| 0.5 * self.params.wheel_inertia * w.spin * w.spin)
                .sum::<f64>()
    }

    /// The soil grid (ruts).
    pub fn soil(&self) -> &SoilGrid {
        &self.state.soil
    }

    /// Physics steps taken.
    pub fn steps(&self) -> u64 {
        self.state.steps
    }

    /// Sets position and velocity directly (tests: launch the vehicle).
    pub fn set_velocity(&mut self, v: Vector3<f64>) {
        self.state.vel = v;
        for w in &mut self.state.wheels {
            let fwd = self.state.rot * Vector3::x();
            w.spin = v.dot(&fwd) / self.params.radius;
        }
    }

    /// Overwrites the chassis state with an observed ground-truth state (position, Cardan angles, world velocity,
    /// body angular velocity, applied steering, time), keeping the wheels' internal state and the soil memory: a
    /// model that tracks a vehicle it does not own (a planner's copy of the world) is corrected with it. The
    /// obstacle near list is refreshed at the new position.
    pub fn set_chassis_state(&mut self, s: &VehicleState) {
        self.state.pos = Vector3::new(s.position[0], s.position[1], s.position[2]);
        self.state.rot = UnitQuaternion::from_euler_angles(s.roll, s.pitch, s.yaw);
        self.state.vel = Vector3::new(s.velocity[0], s.velocity[1], s.velocity[2]);
        self.state.omega = Vector3::new(
            s.angular_velocity[0],
            s.angular_velocity[1],
            s.angular_velocity[2],
        );
        self.state.steering = s.steering;
        self.state.time = s.time;
        self.obstacles.refresh(
            &mut self.state.near,
            self.state.pos.x,
            self.state.pos.y,
            self.params.reach(),
        );
    }

    /// Ground-truth state.
    pub fn state(&self) -> VehicleState {
        let (roll, pitch, yaw) = self.state.rot.euler_angles();
        let fwd = self.state.rot * Vector3::x();
        VehicleState {
            time: self.state.time,
            position: [self.state.pos.x, self.state.pos.y, self.state.pos.z],
            roll,
            pitch,
            yaw,
            velocity: [self.state.vel.x, self.state.vel.y, self.state.vel.z],
            angular_velocity: [self.state.omega.x, self.state.omega.y, self.state.omega.z],
            speed: self.state.vel.dot(&fwd),
            steering: self.state.steering,
        }
    }
}
