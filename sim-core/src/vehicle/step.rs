//! The fixed step, as a pipeline of named phases (each in its own module):
//!
//! 1. [`Simulation::begin_step`] (here): counters, the soil's step, the obstacle near list;
//! 2. `powertrain::steer`: steering rate limit and Ackermann road-wheel angles;
//! 3. `powertrain::drive_torque`: automatic gearbox and the engine torque per spin group;
//! 4. `contact::find_contacts`: each wheel's contact with rigid ground or soil (point, normal, load, soil force);
//! 5. `tyre::force_trials`: tyre friction and soil traction at the old spin, and their slip stiffness;
//! 6. `powertrain::update_spins`: implicit wheel-spin update per spin group, with Coulomb brakes;
//! 7. `suspension::wheel_forces`: contact forces at the new spin, the wheels' vertical DOF and the strut forces on
//!    the chassis;
//! 8. `body::body_contacts`: chassis-ground and chassis/wheel-obstacle contacts;
//! 9. `integrate::integrate`: semi-implicit Euler on the chassis.

use super::simulation::*;
use super::action::Action;
use nalgebra::Vector3;

/// What every phase of one step reads: the step and the chassis frame at its start.
pub(super) struct Frame {
    pub dt: f64,
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
        let mut info = StepInfo::default();
        self.begin_step();
        self.steer(action);
        let frame = Frame {
            dt: self.dt,
            up: self.rot * Vector3::z(),
            fwd: self.rot * Vector3::x(),
            omega_w: self.rot * self.omega,
        };
        let mut wrench = Wrench {
            force: self.gravity * self.mass,
            torque: Vector3::zeros(),
        };
        self.drive_torque(action);
        self.find_contacts(&frame);
        self.force_trials(&frame, action);
        info.drive_power = self.update_spins(frame.dt);
        self.wheel_forces(&frame, &mut wrench);
        info.obstacle_contact = self.body_contacts(&frame, &mut wrench);
        self.integrate(&frame, &wrench);
        info
    }

    fn begin_step(&mut self) {
        self.steps += 1;
        self.soil.begin_step();
        if self.steps.is_multiple_of(OBSTACLE_REFRESH_STEPS) {
            self.obstacles
                .refresh_near(self.pos.x, self.pos.y, self.reach());
        }
    }
}
