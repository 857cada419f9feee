//! The episode runner: drives a vehicle with a planner from a task's start to its goal and scores the episode.
//!
//! The vehicle starts at rest at the task's start facing the goal. The planner acts at its control rate; between
//! its actions the physics runs at the vehicle's fixed step, and simulated time is frozen while the planner thinks.
//! The episode ends on the first of: success (within the goal radius, horizontal distance), overturning (the
//! chassis up-axis below the horizon: a rollover), stuck, leaving the map, timeout, or a planner failure (error, NaN
//! or out-of-range action). A failed trial (stuck or timeout) is then classified as a rollover by the configured
//! [`RolloverRule`](crate::episode::RolloverRule): by default, the paper's "more than 30 degrees of roll at the end
//! of a failed trial". The rules live in [`EpisodeRun`], which the Python SDK's environments step as well.

use crate::episode::{EndReason, EpisodeConfig, EpisodeMetrics, EpisodeResult, Outcome};
use crate::episode_run::EpisodeRun;
use crate::planner::{Action, Observation, Planner, PlannerContext, VehicleState};
use crate::vehicle::VehicleSpec;
use crate::world::{Task, World};
use std::ops::ControlFlow;

pub use crate::episode_run::{control_every, start_pose};

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

/// What stands between the truth and the planner at each control step (the perception layer of the `perception`
/// crate; nothing of it lives here): what the planner observes, and what the vehicle applies of its command.
/// [`Truth`] passes both through unchanged.
pub trait ControlHook {
    /// Turns the true observation into what the planner perceives (called once per control step, in order).
    fn observe(&mut self, world: &World, obs: &mut Observation);
    /// The action the vehicle applies for the planner's command (called once per control step).
    fn actuate(&mut self, command: Action) -> Action;
    /// The world the planner is given at its reset, when it is not the truth (the perception layer's belief before
    /// its first scan); `None`: the truth.
    fn believed_world(&self) -> Option<&World> {
        None
    }
}

/// Ground truth: the planner sees the state as it is and the vehicle applies its command as given.
pub struct Truth;

impl ControlHook for Truth {
    fn observe(&mut self, _: &World, _: &mut Observation) {}

    fn actuate(&mut self, command: Action) -> Action {
        command
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

/// A planner that failed before the first step: no metrics, no trajectory.
fn failed_at_start(reason: EndReason, detail: String) -> EpisodeResult {
    EpisodeResult {
        outcome: Outcome::PlannerFailure,
        reason,
        detail,
        metrics: EpisodeMetrics::default(),
        trajectory: Vec::new(),
    }
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
    run_episode_hooked(world, task, vehicle, planner, cfg, observer, &mut Truth)
}

/// [`run_episode_observed`] with `hook` between the truth and the planner: the planner sees what `hook.observe`
/// makes of each observation, the vehicle applies what `hook.actuate` makes of each command, and `observer` sees
/// the perceived state and the command.
pub fn run_episode_hooked(
    world: &World,
    task: &Task,
    vehicle: &VehicleSpec,
    planner: &mut dyn Planner,
    cfg: &EpisodeConfig,
    observer: &mut dyn EpisodeObserver,
    hook: &mut dyn ControlHook,
) -> EpisodeResult {
    let mut run = EpisodeRun::new(world, task, vehicle, cfg);
    let info = vehicle.info();
    let believed = hook.believed_world();
    let ctx = PlannerContext {
        world: believed.unwrap_or(world),
        task,
        vehicle: &info,
        spec: vehicle,
        sim_dt: run.dt(),
        believed: believed.is_some(),
    };
    if let Err(e) = planner.reset(&ctx) {
        return failed_at_start(e.reason(), e.to_string());
    }
    if let Err(detail) = run.set_control_rate(planner.control_rate_hz()) {
        return failed_at_start(EndReason::PlannerError, detail);
    }
    loop {
        let mut obs = run.observation();
        hook.observe(world, &mut obs);
        let action = match planner.act(&obs) {
            Ok(a) => a,
            Err(e) => {
                run.stop(Outcome::PlannerFailure, e.reason(), e.to_string());
                break;
            }
        };
        // An invalid command reaches the run as given, which refuses it; a valid one goes through the actuation.
        let applied = if action.validate().is_ok() {
            hook.actuate(action)
        } else {
            action
        };
        if run.control(applied).is_err() {
            break;
        }
        if observer.on_control_step(&obs.state, &action).is_break() {
            run.stop(
                Outcome::Cancelled,
                EndReason::Cancelled,
                "cancelled by the caller".into(),
            );
            break;
        }
        if run.advance().ended() {
            break;
        }
    }
    run.finish()
}
