//! Phase 7, wheel forces and suspension: the ground force on each wheel at its new spin (tyre friction and load on
//! rigid ground, the soil's force on soil), the wheel's vertical DOF along the chassis up axis (spring, damper, bump
//! stop, unsprung mass; linearly implicit in its stiff terms), and what reaches the chassis: the strut force at the hard point and the ground force's
//! components across the strut.

use super::dynamics::DynamicsState;
use super::params::{VehicleParams, WheelParams};
use super::scratch::StepScratch;
use super::simulation::*;
use super::step::{Frame, Wrench};
use super::tyre::slip_velocity;
use nalgebra::Vector3;

/// Phase 7: see the module docs. Reads this step's contacts and spins before the update from `scratch`, writes
/// the ground forces there.
pub(super) fn wheel_forces(
    p: &VehicleParams,
    s: &mut DynamicsState,
    scratch: &mut StepScratch,
    frame: &Frame,
    wrench: &mut Wrench,
) {
    // Apply contact forces with the new spins.
    for k in 0..p.wheels.len() {
        let c = scratch.contacts[k];
        // The wheel centre, as `WheelParams::centre_offset` but summed in another order (kept: changing it would move
        // every r3 trajectory by rounding).
        let hard_world = s.pos
            + s.rot
                * (p.wheels[k].hard
                    - Vector3::new(
                        0.0,
                        0.0,
                        p.wheels[k].static_compression.min(p.wheels[k].travel),
                    )
                    + Vector3::new(0.0, 0.0, s.wheels[k].compression));
        let mut ground = Vector3::zeros();
        if c.active {
            if c.soil {
                // The soil's force at the new spin, linearised as in the implicit spin update (the wheel felt
                // this reaction; the chassis must get the same force, or momentum leaks between them).
                let spin = s.wheels[k].spin;
                let spin_change = spin - scratch.spin_before[k];
                let (vsx, vsy) = slip_velocity(s, &c, spin, &frame.omega_w);
                let (damping, _) = p.soil_shear_damping(&c, vsx, vsy, frame.dt);
                ground = c.soil_force
                    + c.tx * (c.spin_force * spin_change + damping[0])
                    + c.normal * (c.spin_lift * spin_change)
                    + c.ty * damping[1];
            } else {
                let w = &s.wheels[k];
                let (vsx, vsy) = slip_velocity(s, &c, w.spin, &frame.omega_w);
                let t = p.tyre_force(w, &c, vsx, vsy, frame.dt);
                s.wheels[k].bristle = t.bristle;
                let f = t.force;
                ground = c.normal * c.load + c.tx * f[0] + c.ty * f[1];
            }
        }
        scratch.ground_forces[k] = ground;
        // Wheel vertical DOF along the chassis up axis, linearly implicit in the stiff terms (tyre or soil
        // contact, spring, damper, bump stop), so the soil's elastic stiffness is stable at the vehicle's step.
        let a_rel = s.accel_prev;
        let gvec = frame.gravity * p.unsprung;
        let along = (ground + gvec - p.unsprung * a_rel).dot(&frame.up);
        let n_up = c.normal.dot(&frame.up);
        let (wp, wm) = (&p.wheels[k], &mut s.wheels[k]);
        let (k_ground, c_ground) = if c.active {
            // The soil's stiffness takes each pressed node on the branch the wheel moves it along (its soft
            // plastic tangent where the rim moves into it, its stiff elastic line where the rim rests or moves
            // away: `SoilContact::normal_stiffness`); the tyre has one stiffness.
            (c.k_normal * n_up * n_up, c.c_normal * n_up * n_up)
        } else {
            (0.0, 0.0)
        };
        let (f_strut_start, k_bump) = strut(wp, wm.compression, wm.compression_rate);
        let stiffness = k_ground + wp.spring + k_bump;
        let damping = c_ground + wp.damper;
        let dt = frame.dt;
        let v = wm.compression_rate;
        wm.compression_rate += dt * (along - f_strut_start - dt * stiffness * v)
            / (p.unsprung + dt * damping + dt * dt * stiffness);
        wm.compression += wm.compression_rate * dt;
        if wm.compression < 0.0 {
            wm.compression = 0.0;
            wm.compression_rate = wm.compression_rate.max(0.0);
        }
        // The chassis gets the strut force the wheel's implicit update applied, at the new compression and rate
        // (spring and damper; the bump stop likewise), so action and reaction match within the step. With the
        // force from the step's start (r8) the chassis felt the wheel's motion a step late, which pumped energy
        // into the pitch and bounce: on snow above 18 m/s the HMMWV porpoised two thirds harder at 4 ms than at 0.5 ms
        // and covered 8.6% less ground in 20 s than at 1 ms (now 0.3%).
        let (f_strut, _) = strut(wp, wm.compression, wm.compression_rate);
        // Chassis: strut force at the hard point plus the ground force components across the strut.
        let across = ground + gvec - frame.up * (ground + gvec).dot(&frame.up);
        let f_chassis = frame.up * f_strut + across;
        wrench.force += f_chassis;
        let arm = if c.active { c.point } else { hard_world };
        wrench.torque +=
            (arm - s.pos).cross(&across) + (hard_world - s.pos).cross(&(frame.up * f_strut));
        if c.active && c.soil {
            // The soil's force acts over the contact patch, not at `c.point` under the centre: the rest of its
            // moment about the wheel's centre (on a sunk wheel the pressure's and damping's moment on the
            // leading arc, which the spin pays as rolling resistance) reaches the chassis too, through the
            // driveline's reaction to the torque that overcomes it (quasi-steady spin, as the rigid tyre's
            // force at its contact point).
            let f = c.soil_force - frame.up * c.soil_force.dot(&frame.up);
            wrench.torque += c.soil_moment + (c.normal * p.radius).cross(&f);
        }
    }
}

/// The strut's force at `compression` and compression `rate` (spring, damper and, beyond the travel, the bump stop;
/// it only pushes) and the bump stop's stiffness there.
fn strut(wp: &WheelParams, compression: f64, rate: f64) -> (f64, f64) {
    let (bump, k_bump) = if compression > wp.travel {
        (
            BUMP_STOP_STIFFNESS * wp.spring * (compression - wp.travel) + wp.damper * rate.max(0.0),
            BUMP_STOP_STIFFNESS * wp.spring,
        )
    } else {
        (0.0, 0.0)
    };
    (
        (wp.spring * compression + wp.damper * rate + bump).max(0.0),
        k_bump,
    )
}
