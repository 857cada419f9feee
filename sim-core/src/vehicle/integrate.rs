//! Phase 9, integration: semi-implicit (symplectic) Euler on the chassis' translation and rotation (velocity first,
//! then position with the new velocity; the quaternion advanced by the body angular velocity and renormalised).
//! Translation carries the whole vehicle's mass across the struts and the sprung mass along them.

use super::dynamics::DynamicsState;
use super::params::VehicleParams;
use super::step::{Frame, Wrench};
use nalgebra::UnitQuaternion;

/// Phase 9: see the module docs.
pub(super) fn integrate(p: &VehicleParams, s: &mut DynamicsState, frame: &Frame, wrench: &Wrench) {
    // Whole-vehicle translation: across the struts the wheels move with the chassis, so the force there
    // accelerates the total mass; along the struts only the sprung mass (the wheels' own vertical DOF carry
    // theirs). The wheels' across-strut inertia force is what `suspension` leaves out of the force it passes on.
    let along = wrench.force.dot(&frame.up);
    let acc = (wrench.force - frame.up * along) / p.total_mass + frame.up * (along / p.mass);
    s.accel_prev = acc;
    s.vel += acc * frame.dt;
    s.pos += s.vel * frame.dt;
    let torque_b = s.rot.inverse() * wrench.torque;
    let gyro = s.omega.cross(&(p.inertia * s.omega));
    s.omega += p.inertia_inv * (torque_b - gyro) * frame.dt;
    s.rot = UnitQuaternion::new_normalize(
        s.rot.into_inner()
            * nalgebra::Quaternion::new(
                1.0,
                0.5 * s.omega.x * frame.dt,
                0.5 * s.omega.y * frame.dt,
                0.5 * s.omega.z * frame.dt,
            ),
    );
    s.time += frame.dt;
}
