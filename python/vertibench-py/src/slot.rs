//! One environment of a vector: an episode of sim-core's [`EpisodeRun`] (the benchmark's own rules), the reward
//! terms of its steps, its task draws and its auto-reset. Pure Rust: the Python classes wrap a vector of these.

use crate::obs::ObsBuf;
use crate::source::Source;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::episode::{EpisodeMetrics, Outcome};
use sim_core::observe::CropSpec;
use sim_core::planner::{Action, Observation, VehicleState};
use sim_core::reward::RewardWeights;
use sim_core::world::World;
use sim_core::{ControlHook, EpisodeRun};
use std::sync::Arc;

/// How an environment that ended comes back (gymnasium's `AutoresetMode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Autoreset {
    /// The step after the last one resets the environment and ignores its action.
    NextStep,
    /// The last step resets the environment at once and returns the new episode's first observation; the last
    /// observation is kept as the final one.
    SameStep,
    /// The caller resets ended environments.
    Disabled,
}

/// How tasks are drawn at each reset.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TaskOrder {
    /// Uniformly at random from the selection, from the environment's own seeded generator.
    Random,
    /// Environment `i` of `n` runs the selected tasks `i, i + n, i + 2n, ...` and wraps around.
    Cycle,
}

/// An episode's end as the environment reports it.
#[derive(Clone, Debug)]
pub struct Ended {
    pub task: usize,
    pub outcome: Outcome,
    pub reason: String,
    pub detail: String,
    pub metrics: EpisodeMetrics,
}

/// What one step of one environment produced (besides its observation).
#[derive(Clone, Debug, Default)]
pub struct StepOut {
    /// progress, roll, pitch, terminal.
    pub terms: [f64; 4],
    pub terminated: bool,
    pub truncated: bool,
    /// The episode that ended on this step (its final observation is in `Slot::final_obs` when auto-reset
    /// happened in the same step, else in `Slot::obs`).
    pub ended: Option<Box<Ended>>,
    /// The environment was reset on this step (next-step auto-reset): the action was ignored.
    pub was_reset: bool,
}

/// One environment.
pub struct Slot {
    pub index: usize,
    pub count: usize,
    rng: ChaCha8Rng,
    draws: usize,
    pub task: usize,
    run: Option<EpisodeRun>,
    /// The episode's perception layer (`None` under `ideal`).
    hook: Option<perception::Perception>,
    pub needs_reset: bool,
    pub obs: ObsBuf,
    pub final_obs: ObsBuf,
    pub out: StepOut,
}

/// Settings shared by every environment of a vector.
pub struct Settings {
    pub crop: Option<CropSpec>,
    pub control_rate_hz: f64,
    pub weights: RewardWeights,
    pub autoreset: Autoreset,
    pub order: TaskOrder,
    /// Between the truth and the observations, as in `vb eval --perception`: the same noise for the same task.
    pub perception: perception::Profile,
}

/// What the layer makes of the true state: the perceived state and, under a map-degrading profile, the believed
/// world the crops are taken from.
fn perceived(
    hook: &mut Option<perception::Perception>,
    world: &World,
    state: VehicleState,
) -> (VehicleState, Option<Arc<World>>) {
    match hook {
        None => (state, None),
        Some(h) => {
            let mut o = Observation {
                state,
                belief: None,
            };
            ControlHook::observe(h, world, &mut o);
            (o.state, o.belief)
        }
    }
}

impl Slot {
    pub fn new(index: usize, count: usize, crop: Option<&CropSpec>) -> Slot {
        Slot {
            index,
            count,
            rng: ChaCha8Rng::seed_from_u64(index as u64),
            draws: 0,
            task: 0,
            run: None,
            hook: None,
            needs_reset: true,
            obs: ObsBuf::new(crop),
            final_obs: ObsBuf::new(crop),
            out: StepOut::default(),
        }
    }

    /// Restarts the environment's task draws from `seed` (environment `i` uses `seed + i`).
    pub fn seed(&mut self, seed: u64) {
        self.rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(self.index as u64));
        self.draws = 0;
    }

    /// Starts a new episode: on `task` when given, else on the next drawn task.
    pub fn reset(&mut self, src: &Source, set: &Settings, task: Option<usize>) {
        let n = src.tasks.len();
        self.task = task.unwrap_or_else(|| match set.order {
            TaskOrder::Random => self.rng.gen_range(0..n),
            TaskOrder::Cycle => (self.index + self.draws * self.count) % n,
        });
        self.draws += 1;
        let (lw, t) = src.get(self.task);
        let mut run = src.start(self.task);
        run.set_control_rate(set.control_rate_hz)
            .expect("the control rate was checked when the environments were made");
        run.set_reward_weights(set.weights);
        self.hook = (!set.perception.is_ideal()).then(|| {
            perception::Perception::new(
                &set.perception,
                &lw.world,
                contracts::TaskId::new(t.world_id, t.index),
                t.start,
                src.episode.seed,
                src.vehicle.info().max_steer,
                1.0 / set.control_rate_hz,
            )
        });
        let (state, belief) = perceived(&mut self.hook, &lw.world, run.state());
        let world = belief.as_deref().unwrap_or(&lw.world);
        self.obs
            .write(&state, world, t.goal, set.crop.as_ref(), belief.is_some());
        self.run = Some(run);
        self.needs_reset = false;
        self.out = StepOut::default();
    }

    /// One control step with `action`; an ended environment is reset as `set.autoreset` says. Errors when the
    /// environment must be reset first (auto-reset disabled, or never reset).
    pub fn step(&mut self, src: &Source, set: &Settings, action: Action) -> Result<(), String> {
        self.out = StepOut::default();
        if self.needs_reset {
            if set.autoreset != Autoreset::NextStep || self.run.is_none() {
                return Err(format!(
                    "environment {} has no running episode: call reset() first",
                    self.index
                ));
            }
            self.reset(src, set, None);
            self.out.was_reset = true;
            return Ok(());
        }
        let run = self.run.as_mut().expect("a running episode");
        // An invalid action ends the episode: `advance` then runs no physics and reports that end; a valid one goes
        // through the actuation.
        let applied = match &mut self.hook {
            Some(h) if action.validate().is_ok() => h.actuate(action),
            _ => action,
        };
        let _ = run.control(applied);
        let step = run.advance();
        let (lw, t) = src.get(self.task);
        let (state, belief) = perceived(&mut self.hook, &lw.world, run.state());
        let world = belief.as_deref().unwrap_or(&lw.world);
        self.obs
            .write(&state, world, t.goal, set.crop.as_ref(), belief.is_some());
        self.out.terms = step.reward.as_array();
        if !step.ended() {
            return Ok(());
        }
        let r = run.finish();
        self.out.truncated = step.truncated;
        self.out.terminated = step.terminated;
        self.out.ended = Some(Box::new(Ended {
            task: self.task,
            outcome: r.outcome,
            reason: r.reason.to_string(),
            detail: r.detail,
            metrics: r.metrics,
        }));
        self.needs_reset = true;
        if set.autoreset == Autoreset::SameStep {
            self.final_obs.copy_from(&self.obs);
            let out = std::mem::take(&mut self.out);
            self.reset(src, set, None);
            self.out = out;
        }
        Ok(())
    }
}
