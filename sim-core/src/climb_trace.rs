//! The steepest-grade scenario at one grade with a per-wheel trace (`vb sim climb --trace`, issue 59 item 3):
//! the figures the Chrono reference harness writes in its `climb --trace`, sampled the same way, so that the two
//! simulators' wheels can be read side by side where their grades part (snow). Forces are the ground's on the wheel,
//! split along the slope's normal and the vehicle's heading in the slope's plane.

use crate::characterize::{climbs_observed, Setup};
use crate::vehicle::{Simulation, VehicleSpec};
use nalgebra::Vector3;

/// One wheel at one instant of a climb.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClimbSample {
    /// Time since the vehicle settled, s.
    pub t: f64,
    /// Wheel index (the vehicle's axles front to rear, left then right) of `wheels` (track contacts included).
    pub wheel: usize,
    pub wheels: usize,
    /// The chassis: position along x and height, m; forward speed, m/s; gear (1 = first).
    pub x: f64,
    pub z: f64,
    pub speed: f64,
    pub gear: usize,
    /// Sinkage below the undeformed surface (soil) or tyre deflection (rigid), m.
    pub sinkage: f64,
    /// Longitudinal slip, positive when driving.
    pub slip: f64,
    /// Spin, rad/s.
    pub omega: f64,
    /// The chassis' speed along the heading in the slope's plane, m/s (sim-core has no wheel-centre velocity of its
    /// own; on a straight climb they differ by the pitch rate times the wheel's height below the centre of mass).
    pub v_fwd: f64,
    /// The ground's force on the wheel along the slope's normal and along the heading, N.
    pub normal: f64,
    pub tractive: f64,
    /// The soil's moment about the axle, N m (negative resists a forward spin); `None` off soil.
    pub moment: Option<f64>,
}

/// Wheel `i`'s name in the harness's trace for a two-axle vehicle (`w<i>` beyond four wheels).
pub fn wheel_name(i: usize, wheels: usize) -> String {
    const FOUR: [&str; 4] = ["front_left", "front_right", "rear_left", "rear_right"];
    if wheels == 4 && i < 4 {
        FOUR[i].to_string()
    } else {
        format!("w{i}")
    }
}

/// Runs [`crate::characterize::climbs`] at `deg`, calling `sample` for every wheel every `every` s (from the first
/// step); returns whether it climbed.
pub fn climb_traced(
    spec: &VehicleSpec,
    setup: &Setup,
    deg: f64,
    every: f64,
    mut sample: impl FnMut(&ClimbSample),
) -> bool {
    let a = deg.to_radians();
    let n = Vector3::new(-a.sin(), 0.0, a.cos());
    let mut t0 = None;
    let mut next = 0.0;
    climbs_observed(spec, setup, deg, |sim: &Simulation| {
        let t = sim.time() - *t0.get_or_insert(sim.time());
        if t + 1e-9 < next {
            return;
        }
        next += every;
        let x_axis = sim.orientation() * Vector3::x();
        let fwd = (x_axis - n * x_axis.dot(&n)).normalize();
        let p = sim.position();
        let s = sim.state();
        let wheels = sim.wheels().count();
        for (wheel, w) in sim.wheels().enumerate() {
            let f = Vector3::from(w.force);
            sample(&ClimbSample {
                t,
                wheel,
                wheels,
                x: p.x,
                z: p.z,
                speed: s.speed,
                gear: sim.gear() + 1,
                sinkage: w.sinkage,
                slip: w.slip,
                omega: w.spin,
                v_fwd: sim.velocity().dot(&fwd),
                normal: f.dot(&n),
                tractive: f.dot(&fwd),
                moment: (w.contact && w.soil).then_some(w.soil_torque),
            });
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::characterize::{climbs, Ground};
    use crate::vehicle::vehicle_by_name;

    /// The traced climb is the scenario itself (same verdict), sampled on schedule; climbing a gentle rigid grade
    /// steadily the wheels carry the vehicle's weight's slope-normal part (Newton: m g cos a within 1%,
    /// `chassis.mass` is the whole vehicle's) and drive forwards.
    #[test]
    fn a_traced_climb_is_the_scenario_and_its_wheels_carry_the_weight() {
        let spec = vehicle_by_name("hmmwv").unwrap();
        let setup = Setup {
            ground: Ground::ALL[0],
            dt: None,
        };
        let mut rows = Vec::new();
        let climbed = climb_traced(&spec, &setup, 10.0, 0.5, |s| rows.push(*s));
        assert_eq!(climbed, climbs(&spec, &setup, 10.0));
        assert!(climbed);
        assert_eq!(rows.len(), 4 * 40, "every 0.5 s for 20 s, four wheels");
        assert!((rows[4].t - 0.5).abs() < 0.01, "{}", rows[4].t);
        // At the end, climbing steadily (no acceleration along the normal).
        let last = &rows[rows.len() - 4..];
        let normal: f64 = last.iter().map(|r| r.normal).sum();
        let weight = spec.chassis.mass * 9.81 * 10f64.to_radians().cos();
        assert!(
            (normal / weight - 1.0).abs() < 0.01,
            "{normal} N against {weight} N"
        );
        assert!(
            last.iter().all(|r| r.tractive > 0.0 && r.omega > 0.0),
            "{last:?}"
        );
        assert_eq!(wheel_name(2, 4), "rear_left");
    }
}
