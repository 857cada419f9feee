//! The fixed step, as a pipeline of named phases (each in its own module). Like rapier's
//! `PhysicsPipeline::step`, the step and its phases are functions of what they read and write, passed as arguments
//! (the vehicle's parameters [`VehicleParams`], the world, the obstacles' broad phase, gravity, the dynamic state
//! [`DynamicsState`], the step's scratch [`StepScratch`], the action), not methods on one bag of fields:
//!
//! 1. [`begin_step`] (here): counters, the soil's step, the obstacle near list;
//! 2. `powertrain::steer`: steering rate limit and Ackermann road-wheel angles;
//! 3. `powertrain::drive_torque`: automatic gearbox and the engine torque per spin group;
//! 4. `contact::find_contacts`: each wheel's contact with rigid ground or soil (point, normal, load, soil force);
//! 5. `tyre::force_trials`: tyre friction and soil traction at the old spin, and their slip stiffness;
//! 6. `powertrain::update_spins`: implicit wheel-spin update per spin group, with Coulomb brakes;
//! 7. `suspension::wheel_forces`: contact forces at the new spin, the wheels' vertical DOF and the strut forces on
//!    the chassis;
//! 8. `body::body_contacts`: chassis-ground and chassis/wheel-obstacle contacts;
//! 9. `integrate::integrate`: semi-implicit Euler on the chassis.

use super::action::Action;
use super::dynamics::DynamicsState;
use super::params::VehicleParams;
use super::scratch::StepScratch;
use super::simulation::*;
use super::{body, contact, integrate, powertrain, suspension, tyre};
use crate::collide::ObstacleSet;
use crate::world::World;
use nalgebra::Vector3;

/// What every phase of one step reads: the step, gravity and the chassis frame at its start.
pub(super) struct Frame {
    pub dt: f64,
    /// Gravity, world frame, m/s^2.
    pub gravity: Vector3<f64>,
    /// Chassis up and forward axes, world frame.
    pub up: Vector3<f64>,
    pub fwd: Vector3<f64>,
    /// Chassis angular velocity, world frame.
    pub omega_w: Vector3<f64>,
}

/// Force and torque (about the centre of mass, world frame) accumulated on the chassis during a step.
pub(super) struct Wrench {
    pub force: Vector3<f64>,
    pub torque: Vector3<f64>,
}

impl Simulation {
    /// Advances the simulation by one fixed step with the given (validated) action.
    pub fn step(&mut self, action: &Action) -> StepInfo {
        self.step_under(self.gravity, action)
    }

    /// [`Simulation::step`] under `gravity` instead of the simulation's (settling ramps it up).
    pub(super) fn step_under(&mut self, gravity: Vector3<f64>, action: &Action) -> StepInfo {
        step(
            &self.params,
            &self.world,
            &mut self.obstacles,
            gravity,
            &mut self.state,
            &mut self.scratch,
            action,
        )
    }
}

/// One fixed step of the vehicle `p` in `world` (see the module docs): advances `s` with `action`, using `scratch`.
pub(super) fn step(
    p: &VehicleParams,
    world: &World,
    obstacles: &mut ObstacleSet,
    gravity: Vector3<f64>,
    s: &mut DynamicsState,
    scratch: &mut StepScratch,
    action: &Action,
) -> StepInfo {
    let mut info = StepInfo::default();
    begin_step(p, obstacles, s);
    powertrain::steer(p, s, action);
    let frame = Frame {
        dt: p.dt,
        gravity,
        up: s.rot * Vector3::z(),
        fwd: s.rot * Vector3::x(),
        omega_w: s.rot * s.omega,
    };
    let mut wrench = Wrench {
        force: gravity * p.mass,
        torque: Vector3::zeros(),
    };
    powertrain::drive_torque(p, s, &mut scratch.groups, action);
    contact::find_contacts(p, world, s, &mut scratch.contacts, &frame);
    tyre::force_trials(p, s, &scratch.contacts, &mut scratch.groups, &frame, action);
    info.drive_power = powertrain::update_spins(p, s, scratch, frame.dt);
    suspension::wheel_forces(p, s, scratch, &frame, &mut wrench);
    info.obstacle_contact = body::body_contacts(p, world, obstacles, s, &frame, &mut wrench);
    integrate::integrate(p, s, &frame, &wrench);
    info
}

/// Phase 1: counts the step, starts the soil's step and refreshes the obstacle near list every
/// [`OBSTACLE_REFRESH_STEPS`].
fn begin_step(p: &VehicleParams, obstacles: &mut ObstacleSet, s: &mut DynamicsState) {
    s.steps += 1;
    s.soil.begin_step();
    if s.steps.is_multiple_of(OBSTACLE_REFRESH_STEPS) {
        obstacles.refresh(&mut s.near, s.pos.x, s.pos.y, p.reach());
    }
}
