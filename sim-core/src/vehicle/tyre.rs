//! Phase 5, tyre and soil force trials: the ground's torque on each wheel in contact at the spin of the previous step
//! and its derivative with respect to the spin, summed per spin group for the implicit spin update. On rigid ground
//! the torque is the tyre model's longitudinal force ([`TyreModel`]) at the rim; on soil the soil's moment about the
//! axle.

use super::action::Action;
use super::dynamics::{DynamicsState, WheelState};
use super::params::VehicleParams;
use super::scratch::{GroupSums, WheelContact};
use super::simulation::*;
use super::step::Frame;
use crate::vehicle::spec::TyreModel;
use nalgebra::Vector3;

/// Tyre friction at one contact: the force `[fx, fy]` in the contact frame, `d fx / d(rim speed)` for the implicit
/// spin update, and the tyre's bristle deflection after this step (unchanged for the handling tyre).
#[derive(Clone, Copy, Debug)]
pub(super) struct TyreForce {
    pub force: [f64; 2],
    pub stiffness: f64,
    pub bristle: [f64; 2],
}

/// Phase 5: see the module docs. Also sums each group's spin inertia, momentum and brake torque into `groups`.
pub(super) fn force_trials(
    p: &VehicleParams,
    s: &DynamicsState,
    contacts: &[WheelContact],
    groups: &mut GroupSums,
    frame: &Frame,
    action: &Action,
) {
    let dt = frame.dt;
    for ((c, w), wp) in contacts.iter().zip(&s.wheels).zip(&p.wheels) {
        let g = wp.group;
        groups.den[g] += p.wheel_inertia;
        groups.spin[g] += w.spin * p.wheel_inertia;
        groups.brake[g] += p.spec.powertrain.brake_torque * action.brake.clamp(0.0, 1.0);
        if !c.active {
            continue;
        }
        let (vsx, vsy) = slip_velocity(s, c, w.spin, &frame.omega_w);
        if c.soil {
            // The soil's moment about the axle and its spin Jacobian; the creep damping acts at the rim.
            let (damping, c_t) = p.soil_shear_damping(c, vsx, vsy, dt);
            groups.num[g] += c.soil_torque - damping[0] * c.r_eff;
            groups.den[g] += dt * (c.spin_stiffness + c_t * c.r_eff * c.r_eff);
        } else {
            let t = p.tyre_force(w, c, vsx, vsy, dt);
            groups.num[g] -= t.force[0] * c.r_eff;
            groups.den[g] += dt * t.stiffness * c.r_eff * c.r_eff;
        }
    }
}

/// Slip velocity of a wheel spinning at `spin` at its contact `c`, in the contact frame: the ground point's
/// velocity (the chassis moving as `s` says) less the rim speed along `tx`, and across it along `ty`.
pub(super) fn slip_velocity(
    s: &DynamicsState,
    c: &WheelContact,
    spin: f64,
    omega_w: &Vector3<f64>,
) -> (f64, f64) {
    let v_p = s.vel + omega_w.cross(&(c.point - s.pos));
    (v_p.dot(&c.tx) - spin * c.r_eff, v_p.dot(&c.ty))
}

impl VehicleParams {
    /// Damping of the soil's elastic shear, as the rigid tyre's bristle damping (LuGre's sigma_1): the pressed
    /// nodes' shear acts as a bristle of stiffness `k = traction_stiffness / dt` (Janosi's initial slope
    /// `tau_max / K` over the contact); its slip velocity `(vsx, vsy)` is damped at [`BRISTLE_DAMPING_RATIO`] of
    /// critical for the wheel's share of the vehicle's mass, and the damped shear stays within the contact's
    /// Mohr-Coulomb capacity. Without it the elastic shear is undamped and a parked vehicle rocks on it (3 Hz for
    /// the HMMWV on mud) and ratchets into the soil. The damping fades out above creep speeds. Returns the force `[fx, fy]` in the contact frame and its
    /// derivative with respect to `vsx` (0 where capped).
    pub(super) fn soil_shear_damping(
        &self,
        c: &WheelContact,
        vsx: f64,
        vsy: f64,
        dt: f64,
    ) -> ([f64; 2], f64) {
        // Rounding can leave a saturated contact's stiffness a hair below zero.
        let k = (c.soil_stiffness / dt).max(0.0);
        let share = self.total_mass / self.wheels.len() as f64;
        // Damping only at creep speeds: it fades as exp(-(v / v_d)^2) (the velocity-dependent bristle damping of
        // Olsson et al., Friction models and friction compensation, Eur. J. Control 4, 1998, eq. 24), so a sliding
        // or spinning wheel gets the soil's Janosi shear alone.
        let v_d = SHEAR_DAMPING_SPEED * self.spec.scale.sqrt();
        let fade = (-(vsx * vsx + vsy * vsy) / (v_d * v_d)).exp();
        let coefficient = 2.0 * BRISTLE_DAMPING_RATIO * (k * share).sqrt() * fade;
        let f = [-coefficient * vsx, -coefficient * vsy];
        let shear = c.soil_force - c.normal * c.soil_force.dot(&c.normal);
        let room = (c.shear_capacity - shear.norm()).max(0.0);
        let norm = f[0].hypot(f[1]);
        if norm > room {
            let s = if norm > 0.0 { room / norm } else { 0.0 };
            ([f[0] * s, f[1] * s], 0.0)
        } else {
            (f, coefficient)
        }
    }

    /// Tyre friction on rigid ground for slip velocities `(vsx, vsy)`: see [`TyreForce`].
    pub(super) fn tyre_force(
        &self,
        w: &WheelState,
        c: &WheelContact,
        vsx: f64,
        vsy: f64,
        dt: f64,
    ) -> TyreForce {
        let lim = c.mu * c.load;
        match self.spec.wheels.tyre {
            TyreModel::Rigid => {
                let trial = [
                    -(self.bristle_k * (w.bristle[0] + vsx * dt)) - self.bristle_c * vsx,
                    -(self.bristle_k * (w.bristle[1] + vsy * dt)) - self.bristle_c * vsy,
                ];
                let norm = trial[0].hypot(trial[1]);
                if norm > lim && norm > 0.0 {
                    // Sliding: the force sits on the friction circle and the bristle relaxes to carry it.
                    let s = vsx.hypot(vsy).max(0.01);
                    let force = [trial[0] / norm * lim, trial[1] / norm * lim];
                    TyreForce {
                        force,
                        stiffness: lim / s,
                        bristle: [-force[0] / self.bristle_k, -force[1] / self.bristle_k],
                    }
                } else {
                    TyreForce {
                        force: trial,
                        stiffness: self.bristle_k * dt + self.bristle_c,
                        bristle: [w.bristle[0] + vsx * dt, w.bristle[1] + vsy * dt],
                    }
                }
            }
            TyreModel::Handling => {
                let v_ref = (w.spin * c.r_eff)
                    .abs()
                    .max((vsx + w.spin * c.r_eff).abs())
                    .max(0.5 * self.spec.scale.sqrt());
                let s = vsx.hypot(vsy) / v_ref;
                // Pacejka's Magic Formula, dry-tarmac set (B 10, C 1.9, D = mu F_z, E 0.97; physics.md section 5):
                // F = D sin(C atan(B s - E (B s - atan(B s)))). Without E the curve falls to a third of its peak
                // when sliding (sin(1.9 atan(10)) = 0.34); with it, to 0.91.
                let (b, cc, e) = (MF_B, MF_C, MF_E);
                let bs = b * s;
                let mag = lim * (cc * (bs - e * (bs - bs.atan())).atan()).sin();
                let stiffness = lim * b * cc / v_ref;
                if s < 1e-9 {
                    return TyreForce {
                        force: [0.0, 0.0],
                        stiffness,
                        bristle: w.bristle,
                    };
                }
                let d = [-vsx / (s * v_ref), -vsy / (s * v_ref)];
                TyreForce {
                    force: [mag * d[0], mag * d[1]],
                    stiffness,
                    bristle: w.bristle,
                }
            }
        }
    }
}
