//! A vehicle's datasheet: standard scenarios on flat or sloped ground of one surface, run with the simulator
//! itself (`vb sim characterize`). Researchers compare vehicles with it, and it documents what the benchmark's
//! physics does: static sinkage and ride height, full-throttle speeds and distance, braking deceleration, the
//! steepest climbable grade, the side-slope angles at which the vehicle slides and tips, and steady turning radii.
//!
//! Every scenario starts from [`Simulation::new`] (placed and settled at rest with brakes on) on a world
//! 1024 m x 1024 m times the vehicle's scale. Lengths, speeds and times of the scenarios scale with the vehicle by
//! Froude similitude (lengths x scale, speeds and times x sqrt(scale)), so a 1/6-scale HMMWV gets the same
//! dimensionless tests.

use crate::planner::Action;
use crate::vehicle::{SimOptions, Simulation, VehicleSpec};
use crate::world::{Heightmap, Semantic, SoilParams, Surface, World, MAP_PX};
use nalgebra::Vector3;
use serde::Serialize;

const G: f64 = 9.81;

/// The ground of a datasheet.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Ground {
    /// Rigid ground; the friction coefficient is combined with the tyre's as the minimum.
    Rigid {
        friction: f64,
    },
    Snow,
    Mud,
    Sand,
}

impl Ground {
    /// Rigid ground at concrete's mean friction (0.85) and the three soils.
    pub const ALL: [Ground; 4] = [
        Ground::Rigid { friction: 0.85 },
        Ground::Snow,
        Ground::Mud,
        Ground::Sand,
    ];

    /// `rigid`, `snow`, `mud` or `sand`.
    pub fn from_name(name: &str) -> Option<Ground> {
        match name {
            "rigid" => Some(Ground::ALL[0]),
            "snow" => Some(Ground::Snow),
            "mud" => Some(Ground::Mud),
            "sand" => Some(Ground::Sand),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Ground::Rigid { .. } => "rigid",
            Ground::Snow => "snow",
            Ground::Mud => "mud",
            Ground::Sand => "sand",
        }
    }

    fn surface(self) -> (Semantic, Surface) {
        let soil = |s: SoilParams, semantic| (semantic, Surface::Deformable { soil: s });
        match self {
            Ground::Rigid { friction } => (Semantic::Concrete, Surface::Rigid { friction }),
            Ground::Snow => soil(SoilParams::SNOW, Semantic::Snow),
            Ground::Mud => soil(SoilParams::MUD, Semantic::Mud),
            Ground::Sand => soil(SoilParams::SAND, Semantic::Sand),
        }
    }
}

/// Scenario settings shared by all scenarios.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup {
    pub ground: Ground,
    /// Physics step (`None`: the vehicle's default).
    pub dt: Option<f64>,
}

/// A plane of `ground` rising along +x at `grade_deg`, 1024 m across (times `scale`).
pub fn test_world(ground: Ground, grade_deg: f64, scale: f64) -> World {
    let cell = 1024.0 / (MAP_PX - 1) as f64 * scale;
    let t = grade_deg.to_radians().tan();
    let (semantic, surface) = ground.surface();
    let mut w = World::uniform(Heightmap::from_fn(cell, |x, _| x * t), semantic, surface);
    w.scale = scale;
    w
}

/// A datasheet: see the module docs. `None` where a scenario found no value (e.g. no tipping before sliding).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Datasheet {
    pub vehicle: String,
    /// The vehicle's scale: the scenarios' lengths scale with it, their times and speeds with its square root.
    pub scale: f64,
    pub surface: &'static str,
    pub dt: f64,
    /// Time the vehicle took to settle at the start, s.
    pub settle_time: f64,
    /// Mean static sinkage (soil) or tyre deflection (rigid) of the wheels, m.
    pub static_sinkage: f64,
    /// Height of the centre of mass above the undeformed ground at rest, m.
    pub ride_height: f64,
    /// Speed at 2, 5, 10 and 20 s under full throttle from rest, m/s; distance at 20 s, m.
    pub speed_at: [(f64, f64); 4],
    pub distance_20s: f64,
    /// Mean deceleration braking fully from 10 m/s to 1 m/s, in g.
    pub braking_decel_g: f64,
    /// Steepest grade climbed from rest at full throttle (heading held), degrees.
    pub climb_grade_deg: f64,
    /// Side slope (ground tilted slowly about the vehicle's length, brakes on) at which it slides, and at which
    /// its uphill wheels lift (tips), degrees.
    pub slide_angle_deg: Option<f64>,
    pub tip_angle_deg: Option<f64>,
    /// Steady turning radius at 3 m/s with half and full steering, m.
    pub turn_radius_half: Option<f64>,
    pub turn_radius_full: Option<f64>,
}

/// Runs every scenario of the datasheet for `spec` on `setup.ground`.
pub fn datasheet(spec: &VehicleSpec, setup: &Setup) -> Datasheet {
    let flat = test_world(setup.ground, 0.0, spec.scale);
    let sim = new_sim(&flat, spec, setup, 0.0);
    let (speed_at, distance_20s) = full_throttle(spec, setup);
    let (slide, tip) = tilt_table(spec, setup);
    Datasheet {
        vehicle: spec.name.clone(),
        scale: spec.scale,
        surface: setup.ground.name(),
        dt: sim.dt(),
        settle_time: sim.settle_time(),
        static_sinkage: mean_sinkage(&sim),
        ride_height: sim.position().z,
        speed_at,
        distance_20s,
        braking_decel_g: braking(spec, setup),
        climb_grade_deg: climb_grade(spec, setup),
        slide_angle_deg: slide,
        tip_angle_deg: tip,
        turn_radius_half: turning_radius(spec, setup, 0.5),
        turn_radius_full: turning_radius(spec, setup, 1.0),
    }
}

fn new_sim(world: &World, spec: &VehicleSpec, setup: &Setup, x: f64) -> Simulation {
    sim_at(world, spec, setup.dt, x * spec.scale, 0.0, 0.0)
}

/// A settled vehicle at `(x, y)` facing `yaw`, stepping at `dt` (default: the vehicle's).
pub(crate) fn sim_at(
    world: &World,
    spec: &VehicleSpec,
    dt: Option<f64>,
    x: f64,
    y: f64,
    yaw: f64,
) -> Simulation {
    let options = SimOptions {
        dt,
        ..SimOptions::default()
    };
    Simulation::with_options(world, spec, x, y, yaw, &options)
}

/// Mean sinkage (tyre deflection on rigid ground) of the wheels in contact, m.
pub fn mean_sinkage(sim: &Simulation) -> f64 {
    let (sum, n) = sim
        .wheels()
        .filter(|w| w.contact)
        .fold((0.0, 0), |(s, n), w| (s + w.sinkage, n + 1));
    if n == 0 {
        0.0
    } else {
        sum / n as f64
    }
}

/// Steering that holds heading 0 ([`steer`]).
fn hold_heading(sim: &Simulation) -> f64 {
    steer(sim, -sim.state().yaw)
}

/// Steering proportional to a heading error `error` (rad, the wanted heading less the vehicle's yaw) and damped by
/// the yaw rate.
pub(crate) fn steer(sim: &Simulation, error: f64) -> f64 {
    (2.0 * error - 0.5 * sim.state().angular_velocity[2]).clamp(-1.0, 1.0)
}

pub(crate) fn act(steering: f64, throttle: f64, brake: f64) -> Action {
    Action {
        steering,
        throttle,
        brake,
    }
}

/// Runs `seconds` (scaled by sqrt(scale)) calling `control` before every step.
pub(crate) fn drive(
    sim: &mut Simulation,
    seconds: f64,
    mut control: impl FnMut(&Simulation) -> Action,
) {
    let steps = (seconds * sim.spec().scale.sqrt() / sim.dt()).round() as usize;
    for _ in 0..steps {
        let a = control(sim);
        sim.step(&a);
    }
}

/// Full throttle from rest with the heading held: speeds at 2, 5, 10, 20 s and the distance at 20 s.
pub fn full_throttle(spec: &VehicleSpec, setup: &Setup) -> ([(f64, f64); 4], f64) {
    let world = test_world(setup.ground, 0.0, spec.scale);
    let mut sim = new_sim(&world, spec, setup, -480.0);
    let x0 = sim.position();
    let mut out = [(2.0, 0.0), (5.0, 0.0), (10.0, 0.0), (20.0, 0.0)];
    let mut t = 0.0;
    for o in &mut out {
        drive(&mut sim, o.0 - t, |s| act(hold_heading(s), 1.0, 0.0));
        t = o.0;
        o.1 = sim.state().speed;
    }
    (out, (sim.position() - x0).xy().norm())
}

/// Mean deceleration (g) braking fully from 10 m/s (scaled) to 1 m/s on flat ground.
pub fn braking(spec: &VehicleSpec, setup: &Setup) -> f64 {
    let world = test_world(setup.ground, 0.0, spec.scale);
    let mut sim = new_sim(&world, spec, setup, -100.0);
    let (v0, v1) = (10.0 * spec.scale.sqrt(), spec.scale.sqrt());
    sim.set_velocity(Vector3::new(v0, 0.0, 0.0));
    let x0 = sim.position().x;
    let limit = (10.0 / sim.dt()) as usize;
    for _ in 0..limit {
        if sim.state().speed <= v1 {
            break;
        }
        sim.step(&act(0.0, 0.0, 1.0));
    }
    let d = sim.position().x - x0;
    let v = sim.state().speed.max(0.0);
    if d <= 0.0 {
        return 0.0;
    }
    (v0 * v0 - v * v) / (2.0 * d) / G
}

/// Whether the vehicle climbs a grade of `deg` from rest at full throttle: after 20 s it is upright on the slope
/// (its up axis within 30 degrees of the slope's normal), has gained at least 3 m (times scale) along the slope
/// from its settled start, and is still climbing at least 0.2 m/s (times sqrt(scale)) on average over the last 5 s.
pub fn climbs(spec: &VehicleSpec, setup: &Setup, deg: f64) -> bool {
    climbs_observed(spec, setup, deg, |_| {})
}

/// [`climbs`], showing `observe` the simulation before every step (a trace's hook: `climb_trace`).
pub fn climbs_observed(
    spec: &VehicleSpec,
    setup: &Setup,
    deg: f64,
    mut observe: impl FnMut(&Simulation),
) -> bool {
    let world = test_world(setup.ground, deg, spec.scale);
    let mut sim = new_sim(&world, spec, setup, -100.0);
    let along = |s: &Simulation| s.position().x / deg.to_radians().cos();
    let start = along(&sim);
    let mut control = |s: &Simulation| {
        observe(s);
        act(hold_heading(s), 1.0, 0.0)
    };
    drive(&mut sim, 15.0, &mut control);
    let x = along(&sim);
    drive(&mut sim, 5.0, &mut control);
    let a = deg.to_radians();
    let slope_normal = Vector3::new(-a.sin(), 0.0, a.cos());
    let upright = (sim.orientation() * Vector3::z()).dot(&slope_normal) > 30f64.to_radians().cos();
    let end = along(&sim);
    // 0.2 m/s for 5 s, both scaled by sqrt(scale): 1 m times scale.
    upright && end - start >= 3.0 * spec.scale && end - x >= 1.0 * spec.scale
}

/// A coasting stop's roll-back (the harness's `roll-back`): settled facing up a `deg` plane of the ground with
/// the brakes on, then throttle and brakes released for `seconds` (scaled by sqrt(scale)). Time, speed along the
/// heading (negative: rolling back) and gear (1 = first) every 0.25 s (times sqrt(scale)), from the release.
pub fn roll_back(
    spec: &VehicleSpec,
    setup: &Setup,
    deg: f64,
    seconds: f64,
) -> Vec<(f64, f64, usize)> {
    let world = test_world(setup.ground, deg, spec.scale);
    let mut sim = new_sim(&world, spec, setup, -100.0);
    let every = (0.25 * spec.scale.sqrt() / sim.dt()).round().max(1.0) as usize;
    let steps = (seconds * spec.scale.sqrt() / sim.dt()).round() as usize;
    let mut out = Vec::with_capacity(steps / every + 1);
    for i in 0..=steps {
        if i % every == 0 {
            let s = sim.state();
            out.push((i as f64 * sim.dt(), s.speed, sim.gear() + 1));
        }
        if i < steps {
            sim.step(&act(0.0, 0.0, 0.0));
        }
    }
    out
}

/// The steepest climbable grade, degrees, by bisection to 0.1 degree between 0 and 60.
pub fn climb_grade(spec: &VehicleSpec, setup: &Setup) -> f64 {
    let (mut lo, mut hi) = (0.0, 60.0);
    if climbs(spec, setup, hi) {
        return hi;
    }
    while hi - lo > 0.1 {
        let mid = 0.5 * (lo + hi);
        if climbs(spec, setup, mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Tilt table: flat ground whose gravity turns slowly (1 degree per second, times sqrt(scale)) about the vehicle's
/// length, uphill to its left, brakes on. Returns the angles at which it slides (sideways speed above 0.05 m/s
/// times sqrt(scale)) and at which it tips (the uphill wheels carry less than 2% of the weight), up to 80 degrees.
pub fn tilt_table(spec: &VehicleSpec, setup: &Setup) -> (Option<f64>, Option<f64>) {
    let world = test_world(setup.ground, 0.0, spec.scale);
    let mut sim = new_sim(&world, spec, setup, 0.0);
    let rate = 1.0 / spec.scale.sqrt();
    let (mut slide, mut tip) = (None, None);
    let weight = spec.chassis.mass * G;
    while sim.time() < 80.0 / rate {
        let deg = sim.time() * rate;
        let a = deg.to_radians();
        sim.set_gravity(Vector3::new(0.0, -G * a.sin(), -G * a.cos()));
        sim.step(&act(0.0, 0.0, 1.0));
        if slide.is_none() && sim.velocity().y.abs() > 0.05 * spec.scale.sqrt() {
            slide = Some(deg);
        }
        let uphill: f64 = sim
            .wheels()
            .filter(|w| w.left)
            .map(|w| w.normal_load.max(0.0))
            .sum();
        if tip.is_none() && uphill < 0.02 * weight {
            tip = Some(deg);
        }
        // Done once it has tipped too, or 5 degrees after it started sliding away (the tilt means nothing then).
        if let Some(slid_at) = slide {
            if tip.is_some() || sim.time() * rate > slid_at + 5.0 {
                break;
            }
        }
    }
    (slide, tip)
}

/// Steady turning radius at 3 m/s (times sqrt(scale)) with constant steering `steer`: speed held by a
/// proportional throttle and brake, radius = speed / yaw rate averaged over the last 5 of 25 s.
pub fn turning_radius(spec: &VehicleSpec, setup: &Setup, steer: f64) -> Option<f64> {
    let world = test_world(setup.ground, 0.0, spec.scale);
    let mut sim = new_sim(&world, spec, setup, 0.0);
    let target = 3.0 * spec.scale.sqrt();
    let control = |s: &Simulation| {
        let e = target - s.state().speed;
        act(
            steer,
            (e / target * 2.0).clamp(0.0, 1.0),
            (-e / target).clamp(0.0, 1.0),
        )
    };
    drive(&mut sim, 20.0, control);
    let (mut speed, mut yaw_rate, mut n) = (0.0, 0.0, 0.0);
    let steps = (5.0 * spec.scale.sqrt() / sim.dt()).round() as usize;
    for _ in 0..steps {
        let a = control(&sim);
        sim.step(&a);
        let s = sim.state();
        speed += s.velocity[0].hypot(s.velocity[1]);
        yaw_rate += s.angular_velocity[2];
        n += 1.0;
    }
    let (speed, yaw_rate) = (speed / n, yaw_rate / n);
    (yaw_rate.abs() > 1e-6 && speed > 0.5 * target).then(|| speed / yaw_rate.abs())
}

/// How a table row formats one datasheet.
type Cell = fn(&Datasheet) -> String;

/// The datasheets as a text table, one column per sheet.
pub fn table(sheets: &[Datasheet]) -> String {
    use std::fmt::Write;
    let rows: [(&str, Cell); 16] = [
        ("surface", |d| d.surface.to_string()),
        ("time step", |d| format!("{:.2} ms", d.dt * 1e3)),
        ("settling time", |d| format!("{:.2} s", d.settle_time)),
        ("static sinkage", |d| {
            format!("{:.1} mm", d.static_sinkage * 1e3)
        }),
        ("CoG above ground", |d| format!("{:.3} m", d.ride_height)),
        ("speed at 2 s", |d| format!("{:.2} m/s", d.speed_at[0].1)),
        ("speed at 5 s", |d| format!("{:.2} m/s", d.speed_at[1].1)),
        ("speed at 10 s", |d| format!("{:.2} m/s", d.speed_at[2].1)),
        ("speed at 20 s", |d| format!("{:.2} m/s", d.speed_at[3].1)),
        ("distance at 20 s", |d| format!("{:.1} m", d.distance_20s)),
        ("braking from 10 m/s", |d| {
            format!("{:.3} g", d.braking_decel_g)
        }),
        ("steepest grade", |d| {
            format!("{:.2} deg", d.climb_grade_deg)
        }),
        ("side slope: slides", |d| opt_deg(d.slide_angle_deg)),
        ("side slope: tips", |d| opt_deg(d.tip_angle_deg)),
        ("turn radius, half steer", |d| opt_m(d.turn_radius_half)),
        ("turn radius, full steer", |d| opt_m(d.turn_radius_full)),
    ];
    let mut out = String::new();
    if let Some(d) = sheets.first() {
        let _ = writeln!(out, "{} datasheet ({})", d.vehicle, crate::SIM_VERSION);
        if d.scale != 1.0 {
            let _ = writeln!(
                out,
                "scale {}: the scenarios' times and speeds are x{:.3} (Froude), lengths x{}",
                d.scale,
                d.scale.sqrt(),
                d.scale
            );
        }
    }
    for (name, cell) in rows {
        let _ = write!(out, "{name:<26}");
        for d in sheets {
            let _ = write!(out, "{:>14}", cell(d));
        }
        out.push('\n');
    }
    out
}

fn opt_deg(v: Option<f64>) -> String {
    v.map_or("none".to_string(), |v| format!("{v:.1} deg"))
}

fn opt_m(v: Option<f64>) -> String {
    v.map_or("none".to_string(), |v| format!("{v:.1} m"))
}
