//! Driving one episode with a planner and recording one frame per control step, as the Python SDK's environments
//! observe it: the state and the goal from sim-core's `observe` (the functions the SDK calls), per wheel sinkage,
//! slip, normal load and contact from the physics step that produced the observation, and, in the full variant,
//! the elevation crop relative to the vehicle's height and the semantics crop. The loop is `run_episode`'s
//! (planner reset, its control rate, act, control, advance), so an episode ends exactly as under `vb eval`.
//! Frames are allocated once per episode, for the longest episode the time limit allows.

use crate::record::{Frames, RecordedEpisode};
use contracts::{EndReason, Outcome};
use sim_core::observe::{
    goal_vector, relative_elevation_crop, semantics_crop, state_vector, CropSpec,
};
use sim_core::planner::{Observation, Planner, PlannerContext, VehicleState};
use sim_core::world::{Task, World};
use sim_core::EpisodeRun;

/// A recorded episode's frames and how it ended (after the rollover rule).
#[derive(Clone, Debug, PartialEq)]
pub struct Recorded {
    pub frames: Frames,
    pub outcome: Outcome,
    pub reason: EndReason,
    pub detail: String,
    /// The final observation, after the last action (gymnasium's terminal observation): the SDK's state and goal
    /// vectors of the state the episode ended in.
    pub final_state: [f64; 15],
    pub final_goal: [f64; 3],
    /// Simulated seconds between two frames.
    pub period: f64,
}

/// Whether an episode can be written: at least one frame, every value finite (state, goal and the final observation
/// as float64, wheels, action, reward terms as float32, crops as float16). An episode whose simulation diverged can
/// hold infinities or NaN in its last frames and its final observation.
pub fn writable(rec: &RecordedEpisode) -> bool {
    const F16_MAX: f32 = 65504.0;
    let f = &rec.frames;
    let fin = |v: &[f32]| v.iter().all(|x| x.is_finite());
    let fin64 = |v: &[f64]| v.iter().all(|x| x.is_finite());
    let crop = |v: &Option<Vec<f32>>| {
        v.as_ref()
            .is_none_or(|v| v.iter().all(|x| x.abs() <= F16_MAX))
    };
    !f.is_empty()
        && fin64(f.state.as_flattened())
        && fin64(f.goal.as_flattened())
        && fin64(&rec.meta.final_state)
        && fin64(&rec.meta.final_goal)
        && fin(&f.wheels)
        && fin(f.action.as_flattened())
        && fin(f.reward_terms.as_flattened())
        && crop(&f.elevation)
        && crop(&f.semantics)
}

/// Frames of an episode of at most `max_time` s at `period` s a frame, with room for the last step.
pub fn frame_capacity(max_time: f64, period: f64) -> usize {
    (max_time / period).ceil().max(0.0) as usize + 2
}

/// Drives `run` with `planner` on `world` and `task` (the planner's context; `run` must have been made for them)
/// until the episode ends, recording every control step; crops when `crop` is given.
pub fn drive(
    mut run: EpisodeRun,
    planner: &mut dyn Planner,
    world: &World,
    task: &Task,
    crop: Option<&CropSpec>,
    max_time: f64,
) -> Recorded {
    let spec = run.simulation().spec().clone();
    let info = spec.info();
    let ctx = PlannerContext {
        world,
        task,
        vehicle: &info,
        spec: &spec,
        sim_dt: run.dt(),
        believed: false,
    };
    let observed = |run: &EpisodeRun| {
        let s = run.state();
        (state_vector(&s), goal_vector(&s, task.goal))
    };
    let failed = |run: &EpisodeRun, reason: EndReason, detail: String| {
        let (final_state, final_goal) = observed(run);
        Recorded {
            frames: Frames::default(),
            outcome: Outcome::PlannerFailure,
            reason,
            detail,
            final_state,
            final_goal,
            period: run.control_period(),
        }
    };
    if let Err(e) = planner.reset(&ctx) {
        return failed(&run, e.reason(), e.to_string());
    }
    if let Err(detail) = run.set_control_rate(planner.control_rate_hz()) {
        return failed(&run, EndReason::PlannerError, detail);
    }
    let period = run.control_period();
    let wheels = run.simulation().wheels().count();
    let cells = crop.map_or(0, |c| c.size * c.size);
    let mut rec = Recorder::new(frame_capacity(max_time, period), wheels, cells, crop);
    loop {
        let s = run.state();
        let action = match planner.act(&Observation {
            state: s,
            belief: None,
        }) {
            Ok(a) => a,
            Err(e) => {
                run.stop(Outcome::PlannerFailure, e.reason(), e.to_string());
                break;
            }
        };
        // The observation's wheels are those of the step that produced it (before this action's physics).
        rec.observe(&run, &s, world, task.goal);
        if run.control(action).is_err() {
            rec.drop_last();
            break;
        }
        let t = run.advance();
        let f = &mut rec.frames;
        f.action.push([
            action.steering as f32,
            action.throttle as f32,
            action.brake as f32,
        ]);
        f.reward_terms.push(t.reward.as_array().map(|v| v as f32));
        f.terminated.push(t.terminated);
        f.truncated.push(t.truncated);
        if t.ended() {
            break;
        }
    }
    // The state after the last advance (the last frame's action applied, or none when the loop stopped before it).
    let (final_state, final_goal) = observed(&run);
    let r = run.finish();
    Recorded {
        frames: rec.frames,
        outcome: r.outcome,
        reason: r.reason,
        detail: r.detail,
        final_state,
        final_goal,
        period,
    }
}

/// The frames being recorded and the crop buffers.
struct Recorder<'a> {
    frames: Frames,
    crop: Option<&'a CropSpec>,
    cells: usize,
    wheels: usize,
    labels: Vec<u8>,
}

impl<'a> Recorder<'a> {
    fn new(capacity: usize, wheels: usize, cells: usize, crop: Option<&'a CropSpec>) -> Self {
        let crops = crop.map(|_| Vec::with_capacity(capacity * cells));
        Recorder {
            frames: Frames {
                state: Vec::with_capacity(capacity),
                goal: Vec::with_capacity(capacity),
                wheels: Vec::with_capacity(capacity * wheels * 4),
                action: Vec::with_capacity(capacity),
                reward_terms: Vec::with_capacity(capacity),
                terminated: Vec::with_capacity(capacity),
                truncated: Vec::with_capacity(capacity),
                elevation: crops.clone(),
                semantics: crops,
            },
            crop,
            cells,
            wheels,
            labels: vec![0; cells],
        }
    }

    /// Appends the observation part of a frame (state, goal, wheels, crops).
    fn observe(&mut self, run: &EpisodeRun, s: &VehicleState, world: &World, goal: [f64; 2]) {
        let f = &mut self.frames;
        // The SDK's float64 values, unrounded: a lite dataset's crops are rebuilt from the recorded pose.
        f.state.push(state_vector(s));
        f.goal.push(goal_vector(s, goal));
        for w in run.simulation().wheels().take(self.wheels) {
            f.wheels.extend_from_slice(&[
                w.sinkage as f32,
                w.slip as f32,
                w.normal_load as f32,
                if w.contact { 1.0 } else { 0.0 },
            ]);
        }
        if let (Some(spec), Some(elev), Some(sem)) =
            (self.crop, f.elevation.as_mut(), f.semantics.as_mut())
        {
            let at = elev.len();
            elev.resize(at + self.cells, 0.0);
            relative_elevation_crop(world, s, spec, &mut elev[at..]);
            semantics_crop(world, s, spec, &mut self.labels);
            sem.extend(self.labels.iter().map(|&l| f32::from(l)));
        }
    }

    /// Removes the observation part of the last frame (its action was refused).
    fn drop_last(&mut self) {
        let f = &mut self.frames;
        let n = f.action.len();
        f.state.truncate(n);
        f.goal.truncate(n);
        f.wheels.truncate(n * self.wheels * 4);
        if let Some(e) = f.elevation.as_mut() {
            e.truncate(n * self.cells);
        }
        if let Some(s) = f.semantics.as_mut() {
            s.truncate(n * self.cells);
        }
    }
}
