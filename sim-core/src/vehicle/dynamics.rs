//! The vehicle's dynamic state ([`DynamicsState`]): everything a step changes and the next step reads. It is the
//! snapshot a model-based planner copies to start each rollout (MPPI-6) and a dataset records;
//! [`Simulation::dynamics`] reads it and [`Simulation::set_dynamics`] writes it.

use super::action::VehicleState;
use super::simulation::{Simulation, StateCopyError};
use crate::collide::NearList;
use crate::soil::SoilGrid;
use nalgebra::{UnitQuaternion, Vector3};

/// One wheel's (or track contact's) dynamic state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct WheelState {
    /// Suspension compression from full droop, m, and its rate, m/s.
    pub(super) compression: f64,
    pub(super) compression_rate: f64,
    /// Spin, rad/s.
    pub(super) spin: f64,
    /// The rigid tyre's bristle deflection (longitudinal, lateral), m.
    pub(super) bristle: [f64; 2],
    /// Road-wheel steering angle, rad.
    pub(super) steer_angle: f64,
    /// Tyre deflection of the previous step (for damping).
    pub(super) deflection: f64,
    /// The wheel's last contact was soil: at its next rigid contact it may sit in a rut below the rigid surface.
    pub(super) from_soil: bool,
    /// How far below the rigid surface the ground under this wheel still is while it climbs out of a soil rut onto
    /// a rigid patch (m; see `contact`). Zero otherwise.
    pub(super) rut_offset: f64,
}

/// What a state belongs to: [`Simulation::set_dynamics`] takes only a state of the same vehicle in a world of the
/// same geometry.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Origin {
    pub(super) vehicle: String,
    /// Heightmap samples per side and spacing.
    pub(super) grid: (usize, usize, f64),
    pub(super) obstacles: usize,
}

/// The dynamic state of a simulated vehicle (the name keeps it apart from [`super::VehicleState`], the
/// ground-truth observation a planner gets): time and step count, the chassis' pose and velocities, gear and
/// steering, every wheel's suspension, spin, tyre and rut state, the obstacles near the vehicle and the soil's
/// memory (ruts, yield pressure, shear). With the vehicle's parameters and the world it determines every later
/// step: a simulation given another's state with [`Simulation::set_dynamics`] (unlimited soil radius) steps
/// bit-identically to it. Cloning it allocates (wheels, soil); setting it does not.
#[derive(Clone, Debug)]
pub struct DynamicsState {
    pub(super) time: f64,
    pub(super) pos: Vector3<f64>,
    pub(super) rot: UnitQuaternion<f64>,
    /// World frame.
    pub(super) vel: Vector3<f64>,
    /// Angular velocity in the chassis frame.
    pub(super) omega: Vector3<f64>,
    pub(super) gear: usize,
    pub(super) steering: f64,
    /// The chassis' acceleration in the last step (the wheels' inertia force along their struts).
    pub(super) accel_prev: Vector3<f64>,
    pub(super) steps: u64,
    pub(super) wheels: Vec<WheelState>,
    /// The obstacles near the vehicle (refreshed every few steps).
    pub(super) near: NearList,
    pub(super) soil: SoilGrid,
    /// How long the last [`Simulation::settle`] took, s.
    pub(super) settle_time: f64,
    pub(super) origin: Origin,
}

impl DynamicsState {
    /// Simulated time, s.
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Physics steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Chassis position (centre of mass), world frame, m.
    pub fn position(&self) -> Vector3<f64> {
        self.pos
    }

    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.rot
    }

    /// Chassis velocity, world frame, m/s.
    pub fn velocity(&self) -> Vector3<f64> {
        self.vel
    }

    /// Chassis angular velocity, chassis frame, rad/s.
    pub fn angular_velocity(&self) -> Vector3<f64> {
        self.omega
    }

    /// The soil's memory (ruts).
    pub fn soil(&self) -> &SoilGrid {
        &self.soil
    }
}

impl Simulation {
    /// The dynamic state (see [`DynamicsState`]).
    pub fn dynamics(&self) -> &DynamicsState {
        &self.state
    }

    /// Puts the vehicle in an observed state ([`VehicleState`]: what a planner observes and the datasets record):
    /// [`Simulation::place`] at its `(x, y)` and yaw, then the observation's chassis position, attitude, linear and
    /// angular velocities, steering and time, each wheel spinning as it would roll without slip at the chassis'
    /// forward speed. What an observation does not hold keeps `place`'s values: the suspension as it settled there,
    /// no tyre bristle deflection, the first gear, and undeformed soil (no rut). This is the start a model-based
    /// planner that sees only the observation would roll out from; the open-loop accuracy report
    /// (`vertibench.kino.report`) rolls the simulator out from it. Non-finite observations are refused.
    pub fn place_observed(&mut self, s: &VehicleState) -> Result<(), StateCopyError> {
        let finite = s
            .position
            .iter()
            .chain(&s.velocity)
            .chain(&s.angular_velocity)
            .chain(&[s.roll, s.pitch, s.yaw, s.steering, s.time])
            .all(|v| v.is_finite());
        if !finite {
            return Err(StateCopyError::NotFinite);
        }
        self.place(s.position[0], s.position[1], s.yaw);
        self.set_chassis_state(&VehicleState {
            steering: s.steering.clamp(-1.0, 1.0),
            ..*s
        });
        self.set_velocity(Vector3::from(s.velocity));
        Ok(())
    }

    /// Makes this simulation's dynamic state a copy of `src` (taken from a simulation with
    /// [`Simulation::dynamics`]): chassis pose and velocities, time and step count, gear and steering, every
    /// wheel's suspension, spin, tyre bristle and deflection, the obstacle near list, and the soil memory (ruts,
    /// yield pressure, shear) within the square of half side `soil_radius` around the vehicle (`f64::INFINITY`:
    /// all of it). `src` must be the state of the same vehicle in a world of the same geometry (checked: spec name,
    /// wheel count, heightmap and soil grid size, obstacle count).
    ///
    /// This is how a planner that uses the simulator as its model (MPPI-6) starts each rollout from the current
    /// state without building a simulation: it allocates nothing (the soil pool was sized by [`Simulation::new`]),
    /// and with an unlimited soil radius the simulation then steps bit-identically to the one `src` came from
    /// (tested).
    pub fn set_dynamics(
        &mut self,
        src: &DynamicsState,
        soil_radius: f64,
    ) -> Result<(), StateCopyError> {
        let dst = &mut self.state;
        if dst.origin.vehicle != src.origin.vehicle || dst.wheels.len() != src.wheels.len() {
            return Err(StateCopyError::Vehicle {
                src: src.origin.vehicle.clone(),
                dst: dst.origin.vehicle.clone(),
            });
        }
        if dst.origin != src.origin || !dst.soil.same_grid(&src.soil) {
            return Err(StateCopyError::World);
        }
        dst.time = src.time;
        dst.pos = src.pos;
        dst.rot = src.rot;
        dst.vel = src.vel;
        dst.omega = src.omega;
        dst.gear = src.gear;
        dst.steering = src.steering;
        dst.accel_prev = src.accel_prev;
        dst.steps = src.steps;
        dst.wheels.copy_from_slice(&src.wheels);
        dst.near = src.near;
        dst.soil
            .copy_memory_from(&src.soil, src.pos.x, src.pos.y, soil_radius);
        Ok(())
    }
}
