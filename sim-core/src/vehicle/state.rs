//! Reading and writing a [`Simulation`]'s state: accessors, the ground-truth [`VehicleState`], copying another
//! simulation's state (model-based planners) and overwriting the chassis with an observation.

use super::simulation::*;
use super::action::VehicleState;
use crate::soil::SoilGrid;
use crate::vehicle::spec::VehicleSpec;
use nalgebra::{UnitQuaternion, Vector3};

impl Simulation {
    /// Physics time step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    pub fn spec(&self) -> &VehicleSpec {
        &self.spec
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn position(&self) -> Vector3<f64> {
        self.pos
    }

    pub fn velocity(&self) -> Vector3<f64> {
        self.vel
    }

    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.rot
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
        self.settle_time
    }

    /// Gear engaged (0 = first).
    pub fn gear(&self) -> usize {
        self.gear
    }

    /// What every wheel (track contact) did in the last step.
    pub fn wheels(&self) -> impl Iterator<Item = WheelReport> + '_ {
        let omega_w = self.rot * self.omega;
        self.wheels
            .iter()
            .zip(&self.contacts)
            .zip(&self.ground_forces)
            .map(move |((w, c), f)| {
                // Inactive contacts are all zeros (no force, no sinkage).
                let slip = if c.active {
                    let (vsx, _) = self.slip_velocity(c, w.spin, &omega_w);
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
                    left: w.side > 0.0,
                    spin: w.spin,
                    compression: w.compression,
                }
            })
    }

    /// Spin rate of every wheel contact, rad/s.
    pub fn wheel_spins(&self) -> impl Iterator<Item = f64> + '_ {
        self.wheels.iter().map(|w| w.spin)
    }

    /// Suspension compression of every wheel from full droop, m.
    pub fn compressions(&self) -> impl Iterator<Item = f64> + '_ {
        self.wheels.iter().map(|w| w.compression)
    }

    /// Total kinetic energy (chassis translation and rotation, wheel spin), J.
    pub fn kinetic_energy(&self) -> f64 {
        0.5 * self.total_mass * self.vel.norm_squared()
            + 0.5 * self.omega.dot(&(self.inertia * self.omega))
            + self
                .wheels
                .iter()
                .map(|w| 0.5 * self.wheel_inertia * w.spin * w.spin)
                .sum::<f64>()
    }

    /// The soil grid (ruts).
    pub fn soil(&self) -> &SoilGrid {
        &self.soil
    }

    /// Physics steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Sets position and velocity directly (tests: launch the vehicle).
    pub fn set_velocity(&mut self, v: Vector3<f64>) {
        self.vel = v;
        for w in &mut self.wheels {
            let fwd = self.rot * Vector3::x();
            w.spin = v.dot(&fwd) / self.radius;
        }
    }

    /// Makes this simulation's dynamic state a copy of `src`'s: chassis pose and velocities, time and step count,
    /// gear and steering, every wheel's suspension, spin, tyre bristle and deflection, the obstacle near list, and
    /// the soil memory (ruts, yield pressure, shear) within the square of half side `soil_radius` around the
    /// vehicle (`f64::INFINITY`: all of it). `src` must simulate the same vehicle in a world of the same geometry
    /// (checked: spec name, wheel count, heightmap and soil grid size, obstacle count).
    ///
    /// This is how a planner that uses the simulator as its model (MPPI-6) starts each rollout from the current
    /// state without building a simulation: it allocates nothing (the soil pool was sized by [`Simulation::new`]),
    /// and with an unlimited soil radius the copy then steps bit-identically to `src` (tested).
    pub fn copy_state_from(
        &mut self,
        src: &Simulation,
        soil_radius: f64,
    ) -> Result<(), StateCopyError> {
        if self.spec.name != src.spec.name || self.wheels.len() != src.wheels.len() {
            return Err(StateCopyError::Vehicle {
                src: src.spec.name.clone(),
                dst: self.spec.name.clone(),
            });
        }
        let (a, b) = (&self.world_patches.heightmap, &src.world_patches.heightmap);
        if a.nx != b.nx
            || a.ny != b.ny
            || a.cell != b.cell
            || self.obstacles.obstacles().len() != src.obstacles.obstacles().len()
            || !self.soil.same_grid(&src.soil)
        {
            return Err(StateCopyError::World);
        }
        self.time = src.time;
        self.pos = src.pos;
        self.rot = src.rot;
        self.vel = src.vel;
        self.omega = src.omega;
        self.gear = src.gear;
        self.steering = src.steering;
        self.accel_prev = src.accel_prev;
        self.steps = src.steps;
        for (w, s) in self.wheels.iter_mut().zip(&src.wheels) {
            w.compression = s.compression;
            w.compression_rate = s.compression_rate;
            w.spin = s.spin;
            w.bristle = s.bristle;
            w.steer_angle = s.steer_angle;
            w.deflection = s.deflection;
            w.from_soil = s.from_soil;
            w.rut_offset = s.rut_offset;
        }
        self.obstacles.copy_near_from(&src.obstacles);
        self.soil
            .copy_memory_from(&src.soil, src.pos.x, src.pos.y, soil_radius);
        Ok(())
    }

    /// Overwrites the chassis state with an observed ground-truth state (position, Cardan angles, world velocity,
    /// body angular velocity, applied steering, time), keeping the wheels' internal state and the soil memory: a
    /// model that tracks a vehicle it does not own (a planner's copy of the world) is corrected with it. The
    /// obstacle near list is refreshed at the new position.
    pub fn set_chassis_state(&mut self, s: &VehicleState) {
        self.pos = Vector3::new(s.position[0], s.position[1], s.position[2]);
        self.rot = UnitQuaternion::from_euler_angles(s.roll, s.pitch, s.yaw);
        self.vel = Vector3::new(s.velocity[0], s.velocity[1], s.velocity[2]);
        self.omega = Vector3::new(
            s.angular_velocity[0],
            s.angular_velocity[1],
            s.angular_velocity[2],
        );
        self.steering = s.steering;
        self.time = s.time;
        self.obstacles
            .refresh_near(self.pos.x, self.pos.y, self.reach());
    }

    /// Ground-truth state.
    pub fn state(&self) -> VehicleState {
        let (roll, pitch, yaw) = self.rot.euler_angles();
        let fwd = self.rot * Vector3::x();
        VehicleState {
            time: self.time,
            position: [self.pos.x, self.pos.y, self.pos.z],
            roll,
            pitch,
            yaw,
            velocity: [self.vel.x, self.vel.y, self.vel.z],
            angular_velocity: [self.omega.x, self.omega.y, self.omega.z],
            speed: self.vel.dot(&fwd),
            steering: self.steering,
        }
    }
}
