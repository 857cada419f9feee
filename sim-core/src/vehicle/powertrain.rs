//! Steering, powertrain and wheel spin: the steering rate limit and Ackermann angles (phase 2), the automatic
//! gearbox and the drive torque of each spin group (phase 3), and the implicit spin update with Coulomb brakes
//! (phase 6). Wheels of a locked driveline share one spin (a spin group); a clutched driveline's wheels spin each on
//! their own, joined by torque-limited clutches; skid-steered vehicles drive their left (group 0) and right (group 1)
//! sides at throttle -/+ steering.

use super::action::Action;
use super::dynamics::DynamicsState;
use super::params::VehicleParams;
use super::scratch::{GroupSums, StepScratch};
use crate::vehicle::spec::SteeringKind;

/// Passes of the clutch solver per step ([`lock_clutches`]).
const CLUTCH_PASSES: usize = 4;

/// A locking clutch of a clutched driveline ([`crate::vehicle::spec::Differential::Clutched`]) between two sets of
/// spin groups behind an open differential, which splits the clutch's torque equally among each set's members:
/// an axle's clutch joins its two wheels (one member a side), the central clutch the front and the rear axle (two).
#[derive(Clone, Copy, Debug)]
pub(super) struct Clutch {
    pub(super) a: [usize; 2],
    pub(super) b: [usize; 2],
    pub(super) members: usize,
    /// Largest torque it passes, N m at the wheels.
    pub(super) limit: f64,
}

/// Steering angles below this (rad) count as straight ahead (no Ackermann correction).
const STRAIGHT_AHEAD: f64 = 1e-6;

/// Phase 2: steering with its rate limit, then each steered wheel's Ackermann angle.
pub(super) fn steer(p: &VehicleParams, s: &mut DynamicsState, action: &Action) {
    let max_delta = p.spec.steering.rate * p.dt;
    s.steering += (action.steering.clamp(-1.0, 1.0) - s.steering).clamp(-max_delta, max_delta);
    let wheelbase = p.spec.wheelbase().max(1e-6);
    let delta = s.steering * p.spec.steering.max_angle;
    for (wp, w) in p.wheels.iter().zip(&mut s.wheels) {
        w.steer_angle = if wp.steered && delta.abs() > STRAIGHT_AHEAD {
            let r = wheelbase / delta.tan();
            let li = wp.steer_factor * wheelbase;
            (li / (r - wp.side * wp.hard.y.abs())).atan()
        } else {
            0.0
        };
    }
}

/// Phase 3: the automatic gearbox shifts on the mean wheel speed; the engine's full-load torque at that speed times
/// the throttle is split over the driven wheels' spin groups, and its closed-throttle torque times one minus the
/// throttle's magnitude joins their brake torque. Clears the spin groups' accumulators.
pub(super) fn drive_torque(
    p: &VehicleParams,
    s: &mut DynamicsState,
    groups: &mut GroupSums,
    action: &Action,
) {
    let pt = &p.spec.powertrain;
    let driven_spin =
        s.wheels.iter().map(|w| w.spin.abs()).sum::<f64>() / s.wheels.len().max(1) as f64;
    let reverse = action.throttle < 0.0;
    let ratio = if reverse {
        pt.reverse_gear.abs()
    } else {
        pt.gears[s.gear]
    } * pt.final_drive;
    let rpm = driven_spin / ratio * 60.0 / std::f64::consts::TAU;
    if !reverse {
        if rpm > pt.upshift_rpm && s.gear + 1 < pt.gears.len() {
            s.gear += 1;
        } else if rpm < pt.downshift_rpm && s.gear > 0 {
            s.gear -= 1;
        }
    }
    // Chrono's ChEngineSimpleMap: both maps read at the clamped engine speed, blended by the throttle. The
    // full-load part drives the way the throttle points; the closed-throttle part (engine braking) resists the
    // wheels' spin, so it joins the brakes' Coulomb torque, which stops a wheel without reversing it. Departure,
    // kept: Chrono's transmission also gives the engine |driveshaft speed| / ratio, but hands the driveline the
    // map's signed torque, so a vehicle rolling back against a forward gear is pushed down the grade by the
    // closed-throttle drag (the harness's `roll-back`: 1.7-1.8 m/s^2 on 8 deg, free rolling 1.37), where this
    // brakes it: a drag that does positive work is an artefact of the map, not an engine.
    let u = action.throttle;
    let full_total = pt.full_load(rpm) / ratio;
    let drag_total = pt
        .closed_throttle(rpm)
        .map(|t| (1.0 - u.abs()).max(0.0) * (-t).max(0.0) / ratio);
    for g in 0..p.groups {
        groups.torque[g] = 0.0;
        groups.num[g] = 0.0;
        groups.den[g] = 0.0;
        groups.brake[g] = 0.0;
        groups.spin[g] = 0.0;
    }
    let n_driven = p.wheels.iter().filter(|w| w.driven).count().max(1) as f64;
    if p.spec.steering.kind == SteeringKind::Skid {
        let st = s.steering;
        let (ul, ur) = ((u - st).clamp(-1.0, 1.0), (u + st).clamp(-1.0, 1.0));
        groups.torque[0] = ul * full_total / 2.0;
        groups.torque[1] = ur * full_total / 2.0;
        if let Some(d) = drag_total {
            groups.brake[0] = d / 2.0;
            groups.brake[1] = d / 2.0;
        }
    } else {
        for w in p.wheels.iter().filter(|w| w.driven) {
            groups.torque[w.group] += u * full_total / n_driven;
            if let Some(d) = drag_total {
                groups.brake[w.group] += d / n_driven;
            }
        }
    }
}

/// Phase 6: each spin group's new spin from its drive torque, the ground's torque at the old spin and its slip
/// stiffness (linearly implicit, so stiff friction is stable), then the locking clutches of a clutched driveline
/// ([`Clutch`]), then the brakes' Coulomb torque (which stops a wheel exactly instead of reversing it). Returns the
/// drive power, W.
pub(super) fn update_spins(
    p: &VehicleParams,
    s: &mut DynamicsState,
    scratch: &mut StepScratch,
    dt: f64,
) -> f64 {
    for (before, w) in scratch.spin_before.iter_mut().zip(&s.wheels) {
        *before = w.spin;
    }
    let groups = &mut scratch.groups;
    for g in 0..p.groups {
        // The members of a group share one spin; this recovers it from the inertia-weighted sum.
        let spin = groups.spin[g] / p.group_inertia[g];
        let den = groups.den[g];
        groups.free[g] = if den > 0.0 {
            spin + dt * (groups.torque[g] + groups.num[g]) / den
        } else {
            spin
        };
    }
    lock_clutches(
        &p.clutches,
        &mut scratch.clutch_torque,
        &mut groups.free,
        &groups.den,
        dt,
    );
    let mut power = 0.0;
    for g in 0..p.groups {
        let den = groups.den[g];
        if den <= 0.0 {
            continue;
        }
        let free = groups.free[g];
        let brake_step = dt * groups.brake[g] / den;
        let new = if free.abs() <= brake_step {
            0.0
        } else {
            free - free.signum() * brake_step
        };
        power += groups.torque[g] * new;
        for (_, w) in p
            .wheels
            .iter()
            .zip(&mut s.wheels)
            .filter(|(wp, _)| wp.group == g)
        {
            w.spin = new;
        }
    }
    power
}

/// The clutches' torques on the groups' free spins `free` (each group's spin before the clutches, its effective
/// inertia over the step `den`, so a torque `T` changes its spin by `dt T / den`): sequential impulses,
/// [`CLUTCH_PASSES`] passes over the clutches, each clutch's accumulated torque (in `torque`) clamped to its limit. A
/// clutch that can hold its two sides together locks them; one that cannot slips at its limit.
fn lock_clutches(clutches: &[Clutch], torque: &mut [f64], free: &mut [f64], den: &[f64], dt: f64) {
    torque.iter_mut().for_each(|t| *t = 0.0);
    for _ in 0..CLUTCH_PASSES {
        for (c, acc) in clutches.iter().zip(torque.iter_mut()) {
            let n = c.members as f64;
            let side = |groups: &[usize; 2], free: &[f64]| {
                let members = &groups[..c.members];
                let mean = members.iter().map(|&g| free[g]).sum::<f64>() / n;
                let mobility = members.iter().map(|&g| dt / den[g]).sum::<f64>() / (n * n);
                (mean, mobility)
            };
            let (wa, ma) = side(&c.a, free);
            let (wb, mb) = side(&c.b, free);
            if !(ma + mb).is_finite() || ma + mb <= 0.0 {
                continue;
            }
            let total = (*acc + (wb - wa) / (ma + mb)).clamp(-c.limit, c.limit);
            let delta = total - *acc;
            *acc = total;
            for &g in &c.a[..c.members] {
                free[g] += dt * delta / (n * den[g]);
            }
            for &g in &c.b[..c.members] {
                free[g] -= dt * delta / (n * den[g]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.004;

    fn axle(limit: f64) -> Clutch {
        Clutch {
            a: [0, 0],
            b: [1, 1],
            members: 1,
            limit,
        }
    }

    #[test]
    fn a_clutch_that_can_hold_locks_its_sides_at_their_momentum_weighted_spin() {
        // Two wheels 1 rad/s apart, effective inertias 2 and 6 kg m^2 (times 1/dt): locking needs
        // dt T / 2 - (-dt T / 6) = 1, T = 1.5 / dt = 375 N m, within a 1000 N m limit; the common spin conserves
        // momentum, (2 * 10 + 6 * 11) / 8 = 10.75.
        let mut free = [10.0, 11.0];
        let den = [2.0, 6.0];
        let mut torque = [0.0];
        lock_clutches(&[axle(1000.0)], &mut torque, &mut free, &den, DT);
        assert!(
            (free[0] - 10.75).abs() < 1e-12 && (free[1] - 10.75).abs() < 1e-12,
            "{free:?}"
        );
        assert!((torque[0] - 375.0).abs() < 1e-9, "{torque:?}");
    }

    #[test]
    fn a_clutch_that_cannot_hold_slips_at_its_limit() {
        // The same wheels with Chrono's HMMWV axle clutch, 100 N m: each side's spin moves by dt 100 / den.
        let mut free = [10.0, 11.0];
        let den = [2.0, 6.0];
        let mut torque = [0.0];
        lock_clutches(&[axle(100.0)], &mut torque, &mut free, &den, DT);
        assert!(
            (free[0] - (10.0 + DT * 100.0 / 2.0)).abs() < 1e-12,
            "{free:?}"
        );
        assert!(
            (free[1] - (11.0 - DT * 100.0 / 6.0)).abs() < 1e-12,
            "{free:?}"
        );
        assert_eq!(torque[0], 100.0);
    }

    #[test]
    fn the_central_clutch_splits_its_torque_between_each_axle_s_wheels() {
        // Front wheels (0, 1) at 10 rad/s, rear (2, 3) at 12, all den 4: locking needs 2 = 2 dt T / 8, T = 2000 N m;
        // with a 50 N m limit the central clutch slips, each axle's wheels sharing its torque: each front wheel
        // gains dt 25 / 4, each rear wheel loses as much; the axle clutches have nothing to do.
        let clutches = [
            axle(100.0),
            Clutch {
                a: [2, 2],
                b: [3, 3],
                members: 1,
                limit: 100.0,
            },
            Clutch {
                a: [0, 1],
                b: [2, 3],
                members: 2,
                limit: 50.0,
            },
        ];
        let mut free = [10.0, 10.0, 12.0, 12.0];
        let den = [4.0; 4];
        let mut torque = [0.0; 3];
        lock_clutches(&clutches, &mut torque, &mut free, &den, DT);
        let step = DT * 25.0 / 4.0;
        for (g, want) in [
            (0, 10.0 + step),
            (1, 10.0 + step),
            (2, 12.0 - step),
            (3, 12.0 - step),
        ] {
            assert!((free[g] - want).abs() < 1e-12, "{free:?}");
        }
        assert_eq!(torque, [0.0, 0.0, 50.0]);
    }
}
