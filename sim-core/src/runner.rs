//! The episode runner: drives a vehicle with a planner from a task's start to its goal and scores the episode.
//!
//! The vehicle starts at rest at the task's start facing the goal. The planner acts at its control rate; between
//! its actions the physics runs at the vehicle's fixed step, and simulated time is frozen while the planner thinks.
//! The episode ends on the first of: success (within the goal radius, horizontal distance), overturning (the
//! chassis up-axis below the horizon: a rollover), stuck, leaving the map, timeout, or a planner failure (error, NaN
//! or out-of-range action). A failed trial (stuck or timeout) is then classified as a rollover by the configured
//! [`RolloverRule`]: by default, the paper's "more than 30 degrees of roll at the end of a failed trial".

use crate::episode::*;
use crate::planner::{Action, Observation, Planner, PlannerContext, VehicleState};
use crate::vehicle::{Simulation, VehicleSpec};
use crate::world::{Task, World};
use std::ops::ControlFlow;

/// Receives every control step of an episode (progress reporting, cancellation).
pub trait EpisodeObserver {
    /// Called after the planner acted; `Break` cancels the episode (outcome `timeout`, reason `cancelled`).
    fn on_control_step(&mut self, state: &VehicleState, action: &Action) -> ControlFlow<()>;
}

/// An observer that does nothing.
pub struct NoObserver;

impl EpisodeObserver for NoObserver {
    fn on_control_step(&mut self, _: &VehicleState, _: &Action) -> ControlFlow<()> {
        ControlFlow::Continue(())
    }
}

/// Running mean / variance / max (Welford).
#[derive(Clone, Copy, Debug, Default)]
struct Running {
    n: f64,
    mean: f64,
    m2: f64,
    max: f64,
}

impl Running {
    fn push(&mut self, v: f64) {
        if self.n == 0.0 {
            self.max = v;
        }
        self.n += 1.0;
        let d = v - self.mean;
        self.mean += d / self.n;
        self.m2 += d * (v - self.mean);
        self.max = self.max.max(v);
    }
    fn stats(&self) -> SignalStats {
        SignalStats {
            mean: self.mean,
            var: if self.n > 0.0 { self.m2 / self.n } else { 0.0 },
            max: self.max,
        }
    }
}

/// Runs one episode with no observer.
pub fn run_episode(
    world: &World,
    task: &Task,
    vehicle: &VehicleSpec,
    planner: &mut dyn Planner,
    cfg: &EpisodeConfig,
) -> EpisodeResult {
    run_episode_observed(world, task, vehicle, planner, cfg, &mut NoObserver)
}

fn finish(
    outcome: Outcome,
    reason: &str,
    detail: String,
    metrics: EpisodeMetrics,
    trajectory: Vec<TrajectorySample>,
) -> EpisodeResult {
    EpisodeResult {
        outcome,
        reason: reason.into(),
        detail,
        metrics,
        trajectory,
    }
}

/// Where and how an episode starts: the task's start, facing the goal: `(x, y, yaw)`.
pub fn start_pose(task: &Task) -> (f64, f64, f64) {
    let yaw = (task.goal[1] - task.start[1]).atan2(task.goal[0] - task.start[0]);
    (task.start[0], task.start[1], yaw)
}

/// Physics steps between two planner actions at `rate_hz` for a physics step `dt` (at least 1).
pub fn control_every(rate_hz: f64, dt: f64) -> u64 {
    ((1.0 / rate_hz) / dt).round().max(1.0) as u64
}

/// Runs one episode, reporting every control step to `observer`.
pub fn run_episode_observed(
    world: &World,
    task: &Task,
    vehicle: &VehicleSpec,
    planner: &mut dyn Planner,
    cfg: &EpisodeConfig,
    observer: &mut dyn EpisodeObserver,
) -> EpisodeResult {
    let scale = world.scale;
    let (x0, y0, yaw) = start_pose(task);
    let mut sim = Simulation::new(world, vehicle, x0, y0, yaw);
    let dt = sim.dt();
    let info = vehicle.info();
    let mut metrics = EpisodeMetrics::default();
    let record_every = cfg
        .record_hz
        .map(|hz| ((1.0 / hz) / dt).round().max(1.0) as u64);
    let mut trajectory = Vec::with_capacity(
        cfg.record_hz
            .map_or(0, |hz| (cfg.max_time * hz).ceil() as usize + 2),
    );
    let ctx = PlannerContext {
        world,
        task,
        vehicle: &info,
        spec: vehicle,
        sim_dt: dt,
    };
    if let Err(e) = planner.reset(&ctx) {
        return finish(
            Outcome::PlannerFailure,
            e.reason(),
            e.to_string(),
            metrics,
            trajectory,
        );
    }
    let rate = planner.control_rate_hz();
    if !(rate.is_finite() && rate > 0.0) {
        return finish(
            Outcome::PlannerFailure,
            "planner_error",
            format!("control rate {rate} Hz is not positive"),
            metrics,
            trajectory,
        );
    }
    let control_every = control_every(rate, dt);
    // Stuck bookkeeping: positions sampled every `sample_dt`, window worth of samples in a ring.
    let sample_dt = 0.5;
    let sample_every = (sample_dt / dt).round().max(1.0) as u64;
    let (window, stuck_distance, stuck_speed) = match cfg.stuck {
        StuckRule::Displacement { distance, window } => (window, distance * scale, f64::NAN),
        StuckRule::Speed { speed, window } => (window, f64::NAN, speed),
    };
    let ring_len = (window / sample_dt).round() as usize + 1;
    let mut ring = vec![[0.0f64; 2]; ring_len.max(2)];
    let mut ring_count = 0usize;
    let mut slow_since = 0.0;
    let goal_radius = cfg.goal_radius * scale;
    let (half_x, half_y) = (world.heightmap.half_x(), world.heightmap.half_y());
    let (mut roll, mut roll_abs, mut pitch, mut pitch_abs) = (
        Running::default(),
        Running::default(),
        Running::default(),
        Running::default(),
    );
    let (mut thr, mut steer) = (Running::default(), Running::default());
    let (mut thr_prev, mut steer_prev) = (0.0, 0.0);
    let mut action = Action::default();
    let mut last_pos = sim.position();
    let mut in_contact = false;
    let mut step: u64 = 0;
    let result = loop {
        let state = sim.state();
        if step.is_multiple_of(control_every) {
            let obs = Observation { state };
            match planner.act(&obs) {
                Ok(a) => {
                    if let Err(msg) = a.validate() {
                        break (Outcome::PlannerFailure, "invalid_action", msg);
                    }
                    action = a;
                }
                Err(e) => break (Outcome::PlannerFailure, e.reason(), e.to_string()),
            }
            if step > 0 {
                metrics.throttle_tv += (action.throttle - thr_prev).abs();
                metrics.steering_tv += (action.steering - steer_prev).abs();
            }
            thr_prev = action.throttle;
            steer_prev = action.steering;
            thr.push(action.throttle);
            steer.push(action.steering);
            if observer.on_control_step(&state, &action).is_break() {
                break (
                    Outcome::Timeout,
                    "cancelled",
                    "cancelled by the caller".into(),
                );
            }
        }
        if let Some(every) = record_every {
            if step.is_multiple_of(every) && trajectory.len() < trajectory.capacity() {
                trajectory.push(TrajectorySample {
                    time: state.time,
                    x: state.position[0],
                    y: state.position[1],
                    z: state.position[2],
                    roll: state.roll,
                    pitch: state.pitch,
                    yaw: state.yaw,
                    speed: state.speed,
                    throttle: action.throttle,
                    steering: action.steering,
                    brake: action.brake,
                });
            }
        }
        let info = sim.step(&action);
        step += 1;
        metrics.energy += info.drive_power.max(0.0) * dt;
        if info.obstacle_contact && !in_contact {
            metrics.obstacle_contacts += 1;
        }
        in_contact = info.obstacle_contact;
        let s = sim.state();
        let (r, p) = (s.roll.to_degrees(), s.pitch.to_degrees());
        roll.push(r);
        roll_abs.push(r.abs());
        pitch.push(p);
        pitch_abs.push(p.abs());
        let pos = sim.position();
        metrics.path_length += (pos - last_pos).xy().norm();
        last_pos = pos;
        if !(pos.x.is_finite() && pos.y.is_finite() && pos.z.is_finite()) {
            break (
                Outcome::Rollover,
                "numerical_failure",
                "the simulation diverged".into(),
            );
        }
        if (pos.x - task.goal[0]).hypot(pos.y - task.goal[1]) < goal_radius {
            break (Outcome::Success, "success", String::new());
        }
        if cfg.rollover == RolloverRule::Immediate && r.abs() > cfg.rollover_deg {
            break (
                Outcome::Rollover,
                "rollover",
                format!("|roll| = {:.1} deg", r.abs()),
            );
        }
        // Body z-axis in the world (R = Rz(yaw) Ry(pitch) Rx(roll)): its vertical component is cos(pitch) cos(roll).
        let up_z = s.pitch.cos() * s.roll.cos();
        if up_z < 0.0 {
            break (
                Outcome::Rollover,
                "rollover",
                format!(
                    "overturned: chassis tilted {:.0} deg (roll {:.0}, pitch {:.0})",
                    up_z.acos().to_degrees(),
                    r,
                    p
                ),
            );
        }
        if pos.x.abs() > half_x || pos.y.abs() > half_y {
            break (Outcome::OffMap, "off_map", String::new());
        }
        if step.is_multiple_of(sample_every) {
            let len = ring.len();
            ring[ring_count % len] = [pos.x, pos.y];
            ring_count += 1;
            if stuck_distance.is_finite() && ring_count >= len {
                let old = ring[ring_count % len];
                if (pos.x - old[0]).hypot(pos.y - old[1]) < stuck_distance {
                    break (
                        Outcome::Stuck,
                        "stuck",
                        format!("moved less than {stuck_distance:.2} m in {window} s"),
                    );
                }
            }
        }
        if stuck_speed.is_finite() {
            if s.speed.abs() >= stuck_speed {
                slow_since = s.time;
            } else if s.time - slow_since >= window {
                break (
                    Outcome::Stuck,
                    "stuck",
                    format!("speed below {stuck_speed} m/s for {window} s"),
                );
            }
        }
        if s.time >= cfg.max_time {
            break (Outcome::Timeout, "timeout", String::new());
        }
    };
    let (outcome, reason, message) =
        classify_failure(cfg, result, &sim.state(), &roll_abs, &pitch_abs);
    let pos = sim.position();
    metrics.time = sim.time();
    metrics.steps = sim.steps();
    metrics.final_goal_distance = (pos.x - task.goal[0]).hypot(pos.y - task.goal[1]);
    metrics.roll = roll.stats();
    metrics.roll_abs = roll_abs.stats();
    metrics.pitch = pitch.stats();
    metrics.pitch_abs = pitch_abs.stats();
    let (t, st) = (thr.stats(), steer.stats());
    metrics.throttle_mean = t.mean;
    metrics.throttle_var = t.var;
    metrics.steering_mean = st.mean;
    metrics.steering_var = st.var;
    finish(outcome, reason, message, metrics, trajectory)
}

/// Applies the rollover rule to a failed trial: a stuck or timed-out episode whose roll (final, or maximum roll or
/// pitch under the release's rule) exceeds the threshold is a rollover; everything else is returned unchanged.
fn classify_failure<'a>(
    cfg: &EpisodeConfig,
    result: (Outcome, &'a str, String),
    end: &VehicleState,
    roll_abs: &Running,
    pitch_abs: &Running,
) -> (Outcome, &'a str, String) {
    let (outcome, reason, message) = result;
    let failed = matches!(outcome, Outcome::Stuck | Outcome::Timeout) && reason != "cancelled";
    if !failed {
        return (outcome, reason, message);
    }
    let what = if message.is_empty() {
        reason.to_string()
    } else {
        format!("{reason}: {message}")
    };
    let thr = cfg.rollover_deg;
    match cfg.rollover {
        RolloverRule::AtFailure if end.roll.to_degrees().abs() > thr => (
            Outcome::Rollover,
            "rollover",
            format!(
                "|roll| = {:.1} deg at the end of a failed trial ({what})",
                end.roll.to_degrees().abs()
            ),
        ),
        RolloverRule::MaxDuringFailure if roll_abs.max.max(pitch_abs.max) > thr => (
            Outcome::Rollover,
            "rollover",
            format!(
                "max |roll| {:.1} deg, max |pitch| {:.1} deg during a failed trial ({what})",
                roll_abs.max, pitch_abs.max
            ),
        ),
        _ => (outcome, reason, message),
    }
}
