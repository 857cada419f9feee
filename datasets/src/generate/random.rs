//! The paper's random exploration: sinusoidal steering at a commanded 2 m/s, on every kind of ground.
//!
//! Episode `i` drives world `i mod n` (worlds in id order, so the rigid, deformable and mixed worlds take turns).
//! Its generator ([`super::episode_seed`]) draws, in this order:
//! - the start, uniform over the world's free area: uniform in the map shrunk by [`EDGE_MARGIN`] m (times the
//!   world scale) on every side, redrawn while it lies in an obstacle's footprint grown by the vehicle's half
//!   diagonal plus [`OBSTACLE_CLEARANCE`] m (scaled);
//! - the heading, uniform in [-pi, pi) (independent of the goal);
//! - the goal, at the task radius (60 m, scaled) from the start in a uniform direction, redrawn while it lies
//!   within [`GOAL_EDGE_MARGIN`] m (scaled) of the map's edge (after [`DRAWS`] tries: towards the map's centre),
//!   so the goal features vary as in the benchmark's tasks;
//! - the sinusoid ([`Sinusoid::draw`]): amplitude A ~ U([`AMPLITUDE`]), period T ~ U([`PERIOD_S`]) s and phase
//!   phi ~ U(0, 2 pi); steering `A sin(2 pi t / T + phi)` at the observation's time `t`.
//!
//! - with [`SpeedProfile::StopAndGo`] only, last, the stops ([`Stops::draw`]);
//! - with [`SpeedProfile::Fast`] only, last, the commanded speed, uniform in [`FAST_SPEED`] m/s.
//!
//! The speed command is [`SPEED`] m/s (with the fast profile, its own draw) through the baselines' speed loop
//! ([`baselines::SpeedControl`]). With stops, every `go + stop` seconds the driver stops for `stop` seconds: full
//! brake in even-numbered stops, throttle and brake released in odd ones (so the vehicle is held, or rolls back, on
//! whatever slope it stands), then starts again from the speed loop's initial state. The paper's constant speed
//! never stands the vehicle still with the throttle off, so a model trained on it alone cannot know what braking or
//! a stop does on a slope. On scaled worlds speeds and times follow Froude similitude: the speed, the period and the
//! stop times are multiplied by `sqrt(scale)`.
//! The episode ends on rollover, stuck, off map, success or the run's time limit; every episode is kept.

use super::recorder::{drive, Recorded};
use crate::spec::SpeedProfile;
use baselines::SpeedControl;
use rand::Rng;
use sim_core::episode::EpisodeConfig;
use sim_core::observe::CropSpec;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::vehicle::{VehicleInfo, VehicleSpec};
use sim_core::world::{Task, World};
use sim_core::EpisodeRun;
use std::collections::BTreeMap;
use std::f64::consts::{PI, TAU};
use std::sync::Arc;
use tasks::generate::TASK_RADIUS;
use tasks::obstacles::occupies;

/// Range of the steering amplitude (steering is in [-1, 1]).
pub const AMPLITUDE: [f64; 2] = [0.2, 1.0];
/// Range of the steering period at full scale, s.
pub const PERIOD_S: [f64; 2] = [2.0, 10.0];
/// Commanded speed at full scale, m/s (the paper's).
pub const SPEED: f64 = 2.0;
/// Distance of a start from the map's edge at full scale, m.
pub const EDGE_MARGIN: f64 = 10.0;
/// Distance of a goal from the map's edge at full scale, m (the task set's goals lie 4 m from it).
pub const GOAL_EDGE_MARGIN: f64 = 4.0;
/// Clearance between the vehicle's footprint circle and an obstacle at a start, full-scale m.
pub const OBSTACLE_CLEARANCE: f64 = 1.0;
/// Range of the driving time between stops at full scale, s (at least 8 m at 2 m/s, so a stop never makes the
/// default stuck rule's 1 m in 10 s fire by itself).
pub const GO_S: [f64; 2] = [5.0, 12.0];
/// Range of a stop's duration at full scale, s.
pub const STOP_S: [f64; 2] = [1.5, 4.0];
/// Range of the fast profile's commanded speed at full scale, m/s: from the paper's 2 m/s to about the speed at
/// which the HMMWV's sharpest turn on level ground reaches the tyres' grip (`v^2 / R_min = mu g`: R_min = wheelbase /
/// tan(max steer) = 3.38 m / tan(21 deg) = 8.8 m, mu 0.8, so 8.3 m/s), so on slopes and bumps the sinusoid's hard
/// turns tip the vehicle over. The nominal speed of the benchmark's planners is 4 m/s.
pub const FAST_SPEED: [f64; 2] = [2.0, 8.0];
/// Brake in a braked stop (the speed loop's full brake).
pub const STOP_BRAKE: f64 = 0.5;
/// Tries for a start or a goal.
pub const DRAWS: usize = 1000;

/// One episode's sinusoidal steering and speed command.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sinusoid {
    pub amplitude: f64,
    /// s.
    pub period: f64,
    /// rad.
    pub phase: f64,
    /// Commanded speed, m/s.
    pub speed: f64,
}

impl Sinusoid {
    /// Draws amplitude, period and phase (see the module documentation) for a world of scale `scale`.
    pub fn draw(rng: &mut impl Rng, scale: f64) -> Sinusoid {
        let time = scale.sqrt();
        Sinusoid {
            amplitude: rng.gen_range(AMPLITUDE[0]..AMPLITUDE[1]),
            period: rng.gen_range(PERIOD_S[0]..PERIOD_S[1]) * time,
            phase: rng.gen_range(0.0..TAU),
            speed: SPEED * time,
        }
    }

    /// Steering at time `t` (s since the episode's start).
    pub fn steering(&self, t: f64) -> f64 {
        self.amplitude * (TAU * t / self.period + self.phase).sin()
    }

    /// The `policy_params` of its episodes.
    pub fn params(&self) -> BTreeMap<String, f64> {
        BTreeMap::from([
            ("amplitude".to_string(), self.amplitude),
            ("period".to_string(), self.period),
            ("phase".to_string(), self.phase),
            ("speed".to_string(), self.speed),
        ])
    }
}

/// One episode's stops: after `offset` seconds of a first `go`, and then every `go + stop` seconds, `stop` seconds
/// without throttle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stops {
    /// Driving time between stops, s.
    pub go: f64,
    /// Duration of a stop, s.
    pub stop: f64,
    /// Time already driven at the episode's start, s, in `[0, go)`: the first stop comes after `go - offset`.
    pub offset: f64,
}

/// What the driver does at one time of a stop-and-go episode.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    Go,
    /// A stop with full brake.
    Brake,
    /// A stop with throttle and brake released.
    Coast,
}

impl Stops {
    /// Draws go, stop and offset for a world of scale `scale`.
    pub fn draw(rng: &mut impl Rng, scale: f64) -> Stops {
        let time = scale.sqrt();
        let go = rng.gen_range(GO_S[0]..GO_S[1]) * time;
        Stops {
            go,
            stop: rng.gen_range(STOP_S[0]..STOP_S[1]) * time,
            offset: rng.gen_range(0.0..go),
        }
    }

    /// The phase at time `t` (s since the episode's start): stops are numbered from 0, even ones braked.
    pub fn phase(&self, t: f64) -> Phase {
        let cycle = self.go + self.stop;
        let u = t.max(0.0) + self.offset;
        let k = (u / cycle).floor();
        if u - k * cycle < self.go {
            Phase::Go
        } else if (k as u64).is_multiple_of(2) {
            Phase::Brake
        } else {
            Phase::Coast
        }
    }
}

/// The random exploration's driver, a [`Planner`]: steering from its [`Sinusoid`] at the observation's time,
/// throttle and brake from the baselines' speed loop to the sinusoid's speed.
#[derive(Clone, Debug)]
pub struct SinusoidDriver {
    sinusoid: Sinusoid,
    stops: Option<Stops>,
    rate_hz: f64,
    speed: SpeedControl,
}

impl SinusoidDriver {
    pub fn new(sinusoid: Sinusoid, stops: Option<Stops>, rate_hz: f64) -> Self {
        SinusoidDriver {
            sinusoid,
            stops,
            rate_hz,
            speed: SpeedControl::new(sinusoid.speed, rate_hz),
        }
    }
}

impl Planner for SinusoidDriver {
    fn name(&self) -> &str {
        "sinusoid"
    }
    fn control_rate_hz(&self) -> f64 {
        self.rate_hz
    }
    fn reset(&mut self, _: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.speed = SpeedControl::new(self.sinusoid.speed, self.rate_hz);
        Ok(())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let t = obs.state.time;
        let phase = self.stops.map_or(Phase::Go, |s| s.phase(t));
        if phase != Phase::Go {
            // Each start begins from the speed loop's initial state.
            self.speed = SpeedControl::new(self.sinusoid.speed, self.rate_hz);
        }
        let (throttle, brake) = match phase {
            Phase::Go => self.speed.command(obs.state.speed),
            Phase::Brake => (0.0, STOP_BRAKE),
            Phase::Coast => (0.0, 0.0),
        };
        Ok(Action {
            steering: self.sinusoid.steering(t).clamp(-1.0, 1.0),
            throttle,
            brake,
        })
    }
}

/// A start drawn uniformly over `world`'s free area for `vehicle` (see the module documentation); `None` when
/// [`DRAWS`] tries all hit obstacles.
pub fn draw_start(world: &World, vehicle: &VehicleInfo, rng: &mut impl Rng) -> Option<[f64; 2]> {
    let s = world.scale;
    let h = &world.heightmap;
    let (hx, hy) = (h.half_x() - EDGE_MARGIN * s, h.half_y() - EDGE_MARGIN * s);
    if !(hx > 0.0 && hy > 0.0) {
        return None;
    }
    let inflation = 0.5 * vehicle.length.hypot(vehicle.width) + OBSTACLE_CLEARANCE * s;
    (0..DRAWS)
        .map(|_| [rng.gen_range(-hx..hx), rng.gen_range(-hy..hy)])
        .find(|p| {
            !world
                .obstacles
                .iter()
                .any(|o| occupies(o, p[0], p[1], inflation))
        })
}

/// A goal at the task radius from `start` in a uniformly drawn direction, inside the map (see the module
/// documentation).
pub fn draw_goal(world: &World, start: [f64; 2], rng: &mut impl Rng) -> [f64; 2] {
    let s = world.scale;
    let r = TASK_RADIUS * s;
    let h = &world.heightmap;
    let (hx, hy) = (
        h.half_x() - GOAL_EDGE_MARGIN * s,
        h.half_y() - GOAL_EDGE_MARGIN * s,
    );
    let at = |a: f64| [start[0] + r * a.cos(), start[1] + r * a.sin()];
    (0..DRAWS)
        .map(|_| at(rng.gen_range(0.0..TAU)))
        .find(|g| g[0].abs() <= hx && g[1].abs() <= hy)
        .unwrap_or_else(|| {
            // Towards the centre: inside, as the map's half width exceeds the radius.
            if start[0] == 0.0 && start[1] == 0.0 {
                at(0.0)
            } else {
                at((-start[1]).atan2(-start[0]))
            }
        })
}

/// What a random episode is drawn to be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RandomStart {
    /// `(x, y, yaw)`, m and rad.
    pub start: [f64; 3],
    pub goal: [f64; 2],
    pub sinusoid: Sinusoid,
    /// With [`SpeedProfile::StopAndGo`] (the fast profile's speed is the sinusoid's).
    pub stops: Option<Stops>,
}

impl RandomStart {
    /// The `policy_params` of its episode: the sinusoid's, and with stops `stop_go`, `stop_duration` and
    /// `stop_offset` (s).
    pub fn params(&self) -> BTreeMap<String, f64> {
        let mut p = self.sinusoid.params();
        if let Some(s) = self.stops {
            p.insert("stop_go".into(), s.go);
            p.insert("stop_duration".into(), s.stop);
            p.insert("stop_offset".into(), s.offset);
        }
        p
    }
}

/// Draws a random episode on `world` (start, heading, goal, sinusoid, and with `profile`'s stops or fast speed those,
/// in that order); `None` when no free start was found.
pub fn draw(
    world: &World,
    vehicle: &VehicleInfo,
    profile: SpeedProfile,
    rng: &mut impl Rng,
) -> Option<RandomStart> {
    let p = draw_start(world, vehicle, rng)?;
    let yaw = rng.gen_range(-PI..PI);
    let goal = draw_goal(world, p, rng);
    let mut sinusoid = Sinusoid::draw(rng, world.scale);
    let stops = match profile {
        SpeedProfile::Constant => None,
        SpeedProfile::StopAndGo => Some(Stops::draw(rng, world.scale)),
        SpeedProfile::Fast => {
            sinusoid.speed = rng.gen_range(FAST_SPEED[0]..FAST_SPEED[1]) * world.scale.sqrt();
            None
        }
    };
    Some(RandomStart {
        start: [p[0], p[1], yaw],
        goal,
        sinusoid,
        stops,
    })
}

/// Drives one random episode from `at` on `world`, under `rules` (the time limit is theirs), at `rate_hz`,
/// recording crops when `crop` is given.
pub fn drive_sinusoid(
    world: &Arc<World>,
    vehicle: &VehicleSpec,
    at: &RandomStart,
    rules: &EpisodeConfig,
    rate_hz: f64,
    crop: Option<&CropSpec>,
) -> Recorded {
    let task = Task {
        world_id: world.id,
        index: u32::MAX,
        start: [at.start[0], at.start[1]],
        goal: at.goal,
        path: vec![[at.start[0], at.start[1]], at.goal],
    };
    let run = EpisodeRun::new_heading(world.clone(), &task, vehicle, rules, at.start[2]);
    let mut driver = SinusoidDriver::new(at.sinusoid, at.stops, rate_hz);
    drive(run, &mut driver, world, &task, crop, rules.max_time)
}
