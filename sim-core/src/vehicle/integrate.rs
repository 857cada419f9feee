//! Phase 9, integration: semi-implicit (symplectic) Euler on the chassis' translation and rotation (velocity first,
//! then position with the new velocity; the quaternion advanced by the body angular velocity and renormalised).
//! Translation carries the whole vehicle's mass across the struts and the sprung mass along them.

use super::simulation::*;
use super::step::{Frame, Wrench};
use nalgebra::UnitQuaternion;

impl Simulation {
    /// Phase 9: see the module docs.
    pub(super) fn integrate(&mut self, frame: &Frame, wrench: &Wrench) {
        // Whole-vehicle translation: across the struts the wheels move with the chassis, so the force there
        // accelerates the total mass; along the struts only the sprung mass (the wheels' own vertical DOF carry
        // theirs). The wheels' across-strut inertia force is what `suspension` leaves out of the force it passes on.
        let along = wrench.force.dot(&frame.up);
        let acc =
            (wrench.force - frame.up * along) / self.total_mass + frame.up * (along / self.mass);
        self.accel_prev = acc;
        self.vel += acc * frame.dt;
        self.pos += self.vel * frame.dt;
        let torque_b = self.rot.inverse() * wrench.torque;
        let gyro = self.omega.cross(&(self.inertia * self.omega));
        self.omega += self.inertia_inv * (torque_b - gyro) * frame.dt;
        self.rot = UnitQuaternion::new_normalize(
            self.rot.into_inner()
                * nalgebra::Quaternion::new(
                    1.0,
                    0.5 * self.omega.x * frame.dt,
                    0.5 * self.omega.y * frame.dt,
                    0.5 * self.omega.z * frame.dt,
                ),
        );
        self.time += frame.dt;
    }
}
