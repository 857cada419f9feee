//! One benchmark episode as a state machine that its caller steps: the episode runner drives it with a planner
//! ([`crate::run_episode`]), the Python SDK's environments with an agent's actions. Both therefore follow exactly
//! the same rules (start, action checks, termination, failure classification, metrics).
//!
//! The cycle is: [`EpisodeRun::observation`] → [`EpisodeRun::control`] (the action for the next control period) →
//! [`EpisodeRun::advance`] (physics up to the next control step, or to the end; it returns the period's
//! [`Transition`]: reward terms, terminated, truncated) → ..., and [`EpisodeRun::finish`] once [`EpisodeRun::end`]
//! is set. Nothing in the cycle allocates.

use crate::episode::*;
use crate::planner::{Action, Observation, VehicleState};
pub use crate::referee::EpisodeEnd;
use crate::referee::Referee;
use crate::reward::{is_time_limit, RewardTerms, RewardWeights};
use crate::vehicle::{Simulation, VehicleSpec};
use crate::world::{Task, World};
use nalgebra::Vector3;
use std::sync::Arc;

/// What one control period ([`EpisodeRun::advance`]) produced, in gymnasium's terms: the reward's terms under the
/// run's [`RewardWeights`] ([`crate::reward`]), and whether the episode ended on it, `truncated` at the time limit
/// ([`is_time_limit`]), `terminated` any other way.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Transition {
    pub reward: RewardTerms,
    pub terminated: bool,
    pub truncated: bool,
}

impl Transition {
    /// Whether the episode has ended (terminated or truncated).
    pub fn ended(&self) -> bool {
        self.terminated || self.truncated
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

/// A running episode (see the module documentation). A clone continues bit-identically: cloning a freshly made run
/// is the cheap way to start the same task again (the start's settling is not repeated).
#[derive(Clone)]
pub struct EpisodeRun {
    sim: Simulation,
    cfg: EpisodeConfig,
    goal: [f64; 2],
    /// The termination and rollover rules.
    referee: Referee,
    /// The world's scale (the reward's progress is in metres at full scale).
    scale: f64,
    /// The weights of [`Transition::reward`] ([`EpisodeRun::set_reward_weights`]).
    weights: RewardWeights,
    /// Goal distance at the end of the last control period (or at the start), m.
    prev_distance: f64,
    control_every: u64,
    record_every: Option<u64>,
    trajectory: Vec<TrajectorySample>,
    metrics: EpisodeMetrics,
    roll: Running,
    roll_abs: Running,
    pitch: Running,
    pitch_abs: Running,
    throttle: Running,
    steering: Running,
    action: Action,
    /// The previous action's throttle and steering (their total variation).
    prev: [f64; 2],
    last_pos: Vector3<f64>,
    in_contact: bool,
    step: u64,
    end: Option<EpisodeEnd>,
}

impl EpisodeRun {
    /// Places the vehicle at the task's start facing the goal, settled at rest, with a control rate of 20 Hz
    /// until [`EpisodeRun::set_control_rate`] says otherwise.
    /// The run copies `world` once into the `Arc` its simulation shares ([`EpisodeRun::new_shared`] takes a shared
    /// one); clones of the run share it.
    pub fn new(world: &World, task: &Task, vehicle: &VehicleSpec, cfg: &EpisodeConfig) -> Self {
        EpisodeRun::new_shared(Arc::new(world.clone()), task, vehicle, cfg)
    }

    /// [`EpisodeRun::new`] in a shared world (no copy of it).
    pub fn new_shared(
        world: Arc<World>,
        task: &Task,
        vehicle: &VehicleSpec,
        cfg: &EpisodeConfig,
    ) -> Self {
        let (_, _, yaw) = start_pose(task);
        EpisodeRun::new_heading(world, task, vehicle, cfg, yaw)
    }

    /// [`EpisodeRun::new_shared`] with the vehicle facing `yaw` (rad) instead of the goal: the datasets' random
    /// exploration starts in any direction.
    pub fn new_heading(
        world: Arc<World>,
        task: &Task,
        vehicle: &VehicleSpec,
        cfg: &EpisodeConfig,
        yaw: f64,
    ) -> Self {
        let (x0, y0) = (task.start[0], task.start[1]);
        let sim = Simulation::new_shared(world, vehicle, x0, y0, yaw);
        let world = sim.world();
        let dt = sim.dt();
        let scale = world.scale;
        let record_every = cfg
            .record_hz
            .map(|hz| ((1.0 / hz) / dt).round().max(1.0) as u64);
        let capacity = cfg
            .record_hz
            .map_or(0, |hz| (cfg.max_time * hz).ceil() as usize + 2);
        let last_pos = sim.position();
        let prev_distance = (last_pos.x - task.goal[0]).hypot(last_pos.y - task.goal[1]);
        EpisodeRun {
            scale,
            weights: RewardWeights::default(),
            prev_distance,
            control_every: control_every(20.0, dt),
            record_every,
            trajectory: Vec::with_capacity(capacity),
            metrics: EpisodeMetrics::default(),
            referee: Referee::new(world, task, cfg, dt),
            roll: Running::default(),
            roll_abs: Running::default(),
            pitch: Running::default(),
            pitch_abs: Running::default(),
            throttle: Running::default(),
            steering: Running::default(),
            action: Action::default(),
            prev: [0.0; 2],
            last_pos,
            in_contact: false,
            step: 0,
            end: None,
            goal: task.goal,
            cfg: cfg.clone(),
            sim,
        }
    }

    /// Physics step, s.
    pub fn dt(&self) -> f64 {
        self.sim.dt()
    }

    /// Sets how often the vehicle takes a new action (before the first [`EpisodeRun::advance`]); a rate that is
    /// not positive and finite is refused with the reason.
    pub fn set_control_rate(&mut self, rate_hz: f64) -> Result<(), String> {
        if !(rate_hz.is_finite() && rate_hz > 0.0) {
            return Err(format!("control rate {rate_hz} Hz is not positive"));
        }
        self.control_every = control_every(rate_hz, self.sim.dt());
        Ok(())
    }

    /// Sets the weights of the reward terms that [`EpisodeRun::advance`] reports (default
    /// [`RewardWeights::default`]).
    pub fn set_reward_weights(&mut self, weights: RewardWeights) {
        self.weights = weights;
    }

    /// The weights of the reward terms.
    pub fn reward_weights(&self) -> &RewardWeights {
        &self.weights
    }

    /// Simulated seconds between two actions.
    pub fn control_period(&self) -> f64 {
        self.control_every as f64 * self.sim.dt()
    }

    /// The vehicle's state now.
    pub fn state(&self) -> VehicleState {
        self.sim.state()
    }

    /// What a planner observes now.
    pub fn observation(&self) -> Observation {
        Observation {
            state: self.sim.state(),
            belief: None,
        }
    }

    /// Horizontal distance from the chassis reference point to the goal, m.
    pub fn goal_distance(&self) -> f64 {
        let p = self.sim.position();
        (p.x - self.goal[0]).hypot(p.y - self.goal[1])
    }

    /// How the episode ended, once it has.
    pub fn end(&self) -> Option<&EpisodeEnd> {
        self.end.as_ref()
    }

    /// The simulation (read-only: wheel reports, soil).
    pub fn simulation(&self) -> &Simulation {
        &self.sim
    }

    /// Takes the action for the next control period. An invalid action (NaN, out of range) ends the episode as a
    /// planner failure with reason `invalid_action`.
    pub fn control(&mut self, action: Action) -> Result<(), &EpisodeEnd> {
        if let Err(msg) = action.validate() {
            return Err(self.stop(Outcome::PlannerFailure, EndReason::InvalidAction, msg));
        }
        self.action = action;
        if self.step > 0 {
            self.metrics.throttle_tv += (action.throttle - self.prev[0]).abs();
            self.metrics.steering_tv += (action.steering - self.prev[1]).abs();
        }
        self.prev = [action.throttle, action.steering];
        self.throttle.push(action.throttle);
        self.steering.push(action.steering);
        Ok(())
    }

    /// Ends the episode from outside (a planner failure, a cancellation); an episode that has ended keeps its end.
    pub fn stop(&mut self, outcome: Outcome, reason: EndReason, detail: String) -> &EpisodeEnd {
        self.end
            .get_or_insert_with(|| EpisodeEnd::new(outcome, reason, detail))
    }

    /// Runs the physics with the current action up to the next control step, or until the episode ends, and
    /// returns what the period produced ([`Transition`]): the reward's terms since the last call (or the start),
    /// from the goal distances before and after, the attitude at its end and, on the period that ended the
    /// episode, the terminal term of its outcome after the rollover rule. An episode that has ended (by this
    /// period, an invalid action or [`EpisodeRun::stop`]) runs no physics; its transition says how it ended.
    pub fn advance(&mut self) -> Transition {
        while self.end.is_none() {
            self.physics_step();
            if self.step.is_multiple_of(self.control_every) {
                break;
            }
        }
        let before = self.prev_distance;
        let after = self.goal_distance();
        self.prev_distance = after;
        let s = self.sim.state();
        let end = self.end.as_ref().map(|e| {
            let outcome = if self.referee.rolled_over(e.outcome, s.roll) {
                Outcome::Rollover
            } else {
                e.outcome
            };
            (e, outcome)
        });
        let reward = self.weights.terms(
            before,
            after,
            s.roll,
            s.pitch,
            self.cfg.rollover_deg,
            self.scale,
            end,
        );
        let truncated = self.end.as_ref().is_some_and(is_time_limit);
        Transition {
            reward,
            terminated: self.end.is_some() && !truncated,
            truncated,
        }
    }

    fn physics_step(&mut self) {
        let dt = self.sim.dt();
        if let Some(every) = self.record_every {
            if self.step.is_multiple_of(every) && self.trajectory.len() < self.trajectory.capacity()
            {
                let state = self.sim.state();
                let a = &self.action;
                self.trajectory.push(TrajectorySample {
                    time: state.time,
                    x: state.position[0],
                    y: state.position[1],
                    z: state.position[2],
                    roll: state.roll,
                    pitch: state.pitch,
                    yaw: state.yaw,
                    speed: state.speed,
                    throttle: a.throttle,
                    steering: a.steering,
                    brake: a.brake,
                });
            }
        }
        let info = self.sim.step(&self.action);
        self.step += 1;
        self.metrics.energy += info.drive_power.max(0.0) * dt;
        if info.obstacle_contact && !self.in_contact {
            self.metrics.obstacle_contacts += 1;
        }
        self.in_contact = info.obstacle_contact;
        let s = self.sim.state();
        let (r, p) = (s.roll.to_degrees(), s.pitch.to_degrees());
        self.roll.push(r);
        self.roll_abs.push(r.abs());
        self.pitch.push(p);
        self.pitch_abs.push(p.abs());
        let pos = self.sim.position();
        self.metrics.path_length += (pos - self.last_pos).xy().norm();
        self.last_pos = pos;
        self.end = self.referee.check(self.step, &s);
    }

    /// The episode's result: its end classified by the rollover rule, its metrics and trajectory (moved out). An
    /// episode that has not ended is reported as cancelled.
    pub fn finish(&mut self) -> EpisodeResult {
        let end = self.end.clone().unwrap_or_else(|| {
            EpisodeEnd::new(
                Outcome::Cancelled,
                EndReason::Cancelled,
                "cancelled by the caller",
            )
        });
        let (outcome, reason, detail) = self.referee.classify(end, self.sim.state().roll);
        let m = &mut self.metrics;
        let pos = self.sim.position();
        m.time = self.sim.time();
        m.steps = self.sim.steps();
        m.final_goal_distance = (pos.x - self.goal[0]).hypot(pos.y - self.goal[1]);
        m.roll = self.roll.stats();
        m.roll_abs = self.roll_abs.stats();
        m.pitch = self.pitch.stats();
        m.pitch_abs = self.pitch_abs.stats();
        let (t, st) = (self.throttle.stats(), self.steering.stats());
        m.throttle_mean = t.mean;
        m.throttle_var = t.var;
        m.steering_mean = st.mean;
        m.steering_var = st.var;
        EpisodeResult {
            outcome,
            reason,
            detail,
            metrics: m.clone(),
            trajectory: std::mem::take(&mut self.trajectory),
        }
    }
}
