//! Steering, powertrain and wheel spin: the steering rate limit and Ackermann angles (phase 2), the automatic
//! gearbox and the drive torque of each spin group (phase 3), and the implicit spin update with Coulomb brakes
//! (phase 6). Wheels of a locked driveline share one spin (a spin group); skid-steered vehicles drive their left
//! (group 0) and right (group 1) sides at throttle -/+ steering.

use super::simulation::*;
use crate::planner::Action;
use crate::vehicle::spec::SteeringKind;

/// Steering angles below this (rad) count as straight ahead (no Ackermann correction).
const STRAIGHT_AHEAD: f64 = 1e-6;

impl Simulation {
    /// Phase 2: steering with its rate limit, then each steered wheel's Ackermann angle.
    pub(super) fn steer(&mut self, action: &Action) {
        let max_delta = self.spec.steering.rate * self.dt;
        self.steering +=
            (action.steering.clamp(-1.0, 1.0) - self.steering).clamp(-max_delta, max_delta);
        let wheelbase = self.spec.wheelbase().max(1e-6);
        let delta = self.steering * self.spec.steering.max_angle;
        for w in &mut self.wheels {
            w.steer_angle = if w.steered && delta.abs() > STRAIGHT_AHEAD {
                let r = wheelbase / delta.tan();
                let li = w.steer_factor * wheelbase;
                (li / (r - w.side * w.hard.y.abs())).atan()
            } else {
                0.0
            };
        }
    }

    /// Phase 3: the automatic gearbox shifts on the mean wheel speed, the engine's full-load torque at that speed
    /// times the throttle is split over the driven wheels' spin groups. Clears the spin groups' accumulators.
    pub(super) fn drive_torque(&mut self, action: &Action) {
        let pt = &self.spec.powertrain;
        let driven_spin =
            self.wheels.iter().map(|w| w.spin.abs()).sum::<f64>() / self.wheels.len().max(1) as f64;
        let reverse = action.throttle < 0.0;
        let ratio = if reverse {
            pt.reverse_gear.abs()
        } else {
            pt.gears[self.gear]
        } * pt.final_drive;
        let rpm = driven_spin / ratio * 60.0 / std::f64::consts::TAU;
        if !reverse {
            if rpm > pt.upshift_rpm && self.gear + 1 < pt.gears.len() {
                self.gear += 1;
            } else if rpm < pt.downshift_rpm && self.gear > 0 {
                self.gear -= 1;
            }
        }
        let motor_torque = self.torque_curve(rpm);
        let wheel_torque_total = motor_torque / ratio;
        for g in 0..self.groups {
            self.group_torque[g] = 0.0;
            self.group_num[g] = 0.0;
            self.group_den[g] = 0.0;
            self.group_brake[g] = 0.0;
            self.group_spin[g] = 0.0;
        }
        let n_driven = self.wheels.iter().filter(|w| w.driven).count().max(1) as f64;
        if self.spec.steering.kind == SteeringKind::Skid {
            let s = self.steering;
            let (ul, ur) = (
                (action.throttle - s).clamp(-1.0, 1.0),
                (action.throttle + s).clamp(-1.0, 1.0),
            );
            self.group_torque[0] = ul * wheel_torque_total / 2.0;
            self.group_torque[1] = ur * wheel_torque_total / 2.0;
        } else {
            for w in self.wheels.iter().filter(|w| w.driven) {
                self.group_torque[w.group] += action.throttle * wheel_torque_total / n_driven;
            }
        }
    }

    /// Phase 6: each spin group's new spin from its drive torque, the ground's torque at the old spin and its slip
    /// stiffness (linearly implicit, so stiff friction is stable), then the brakes' Coulomb torque (which stops a
    /// wheel exactly instead of reversing it). Returns the drive power, W.
    pub(super) fn update_spins(&mut self, dt: f64) -> f64 {
        for (before, w) in self.spin_before.iter_mut().zip(&self.wheels) {
            *before = w.spin;
        }
        let mut power = 0.0;
        for g in 0..self.groups {
            let den = self.group_den[g];
            if den <= 0.0 {
                continue;
            }
            // The members of a group share one spin; this recovers it from the inertia-weighted sum.
            let spin = self.group_spin[g] / self.group_inertia[g];
            let free = spin + dt * (self.group_torque[g] + self.group_num[g]) / den;
            let brake_step = dt * self.group_brake[g] / den;
            let new = if free.abs() <= brake_step {
                0.0
            } else {
                free - free.signum() * brake_step
            };
            power += self.group_torque[g] * new;
            for w in self.wheels.iter_mut().filter(|w| w.group == g) {
                w.spin = new;
            }
        }
        power
    }

    /// Engine full-load torque at `rpm` (linear in the spec's curve, zero beyond its last point), N m.
    fn torque_curve(&self, rpm: f64) -> f64 {
        let c = &self.spec.powertrain.torque_curve;
        let rpm = rpm.max(0.0);
        for w in c.windows(2) {
            if rpm <= w[1][0] {
                let t = ((rpm - w[0][0]) / (w[1][0] - w[0][0])).clamp(0.0, 1.0);
                return w[0][1] + (w[1][1] - w[0][1]) * t;
            }
        }
        0.0
    }
}
