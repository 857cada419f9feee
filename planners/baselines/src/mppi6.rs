//! MPPI-6 with an oracle model (`mppi6-oracle`): MPPI whose rollouts use a full 6-DoF model of the vehicle on the
//! terrain (the hybrid class of the paper). The model is **our own simulator** (`sim_core::Simulation`, the same vehicle model, soil and obstacles
//! as the benchmark's) on the planner's own copy of the world: an **oracle model**, far more accurate than the
//! learned 6-DoF model (an ensemble MLP with a CNN elevation encoder) of the original MPPI6. Results of this
//! planner are therefore an upper bound on what the same sampling planner achieves with a learned model (the
//! built-in `mppi6`, `learned::kino::KinoMppi`, shares its knots, speed control and costs: `crate::hybrid`).
//!
//! What it reads: the ground-truth maps (heights, semantic patches with their friction or soil, obstacles), the
//! global path, the vehicle's own model parameters (`PlannerContext::spec`) and the ground-truth state at every
//! control step. It keeps a *shadow* simulation that replays its own actions from the episode's start (so wheel
//! spins, suspension and its own ruts in the soil are tracked) and is corrected with the observed chassis state
//! (pose, velocities, steering) at every decision. It never touches the episode's simulation.
//!
//! Every [`Mppi6Config::replan_every`] control steps (default 4 Hz) it samples `K` control sequences around the
//! previous plan shifted by the replanning period (warm start): [`KNOTS`] knots of (steering, speed factor)
//! spread over the horizon, linearly interpolated between them; the speed factor (-0.5 .. 1; negative backs up)
//! times the nominal speed is the target of the same PI speed controller the baselines use, run at 20 Hz inside
//! the rollouts exactly as in execution. Sample 0 is the shifted plan itself, samples 1-3 are hard left, hard
//! right (at 0.6 of the nominal speed) and backing up straight; the rest add Gaussian noise to the plan. Each
//! rollout copies the shadow's state (chassis, wheels, obstacle near list, soil memory near the vehicle) into one
//! preallocated rollout simulation (`Simulation::set_dynamics` with the shadow's `Simulation::dynamics`) and steps it at the simulator's own time step.
//!
//! Cost per control step, averaged over the horizon:
//! `10 (D(x_t) - D(x_0)) / (v H) + 2 (d / d0)^2 + 2 (roll / 30 deg)^2 + (pitch / 30 deg)^2`, where `D` is the cost-to-go (the shortest distance to the goal on
//! the map grid around the obstacles inflated by half the vehicle's width, computed once per episode), `v H` the
//! distance driven in a horizon at the nominal speed, `d` the distance to the local goal 10 m (scaled) ahead on the
//! global path and `d0` its distance at the decision; `|roll| > 25 deg` adds 20 per step. Touching an obstacle ends
//! the rollout with a penalty of 100, a rollover (|roll| > 30 deg) or leaving the map with 200; reaching the goal
//! ends it, its remaining steps costed as spent at the goal. The new plan is the softmin-weighted mean of the samples (temperature: 0.1 times
//! the spread between the best and the median cost). Noise comes from a generator seeded by the task id, so an
//! episode is reproducible and bit-identical at any thread count.
//!
//! Cost per decision (defaults: K = 24, 1.5 s horizon): K x 1.5 s of simulation, about 9400 physics steps of the
//! full-scale HMMWV, measured at about 44 ms of CPU on average over rigid and soft worlds; the 1000-task evaluation
//! took 3940 s on 2 cores (BENCHMARKS.md).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sim_core::control::point_ahead;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::runner::{control_every, start_pose};
use sim_core::Simulation;

pub use crate::hybrid::KNOTS;
use crate::hybrid::{
    interp, softmin_plan, speed_control, step_cost, CostToGo, ROLLOVER_DEG, SPEED_MAX, SPEED_MIN,
};

/// Rate of `act` (and of the speed controller), Hz.
const RATE: f64 = 20.0;

/// Tunable parameters of [`Mppi6`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mppi6Config {
    /// Samples per decision.
    pub samples: usize,
    /// Rollout horizon, s (at full scale; scaled by sqrt(scale) like the time step).
    pub horizon: f64,
    /// Control steps (at 20 Hz) between decisions.
    pub replan_every: usize,
    /// Noise standard deviations of the steering and speed-factor knots.
    pub sigma_steer: f64,
    pub sigma_speed: f64,
}

impl Default for Mppi6Config {
    fn default() -> Self {
        Mppi6Config {
            samples: 24,
            horizon: 1.5,
            replan_every: 5,
            sigma_steer: 0.45,
            sigma_speed: 0.35,
        }
    }
}

/// The MPPI-6 baseline (oracle 6-DoF model: our own simulator).
#[derive(Debug)]
pub struct Mppi6 {
    cfg: Mppi6Config,
    path: Vec<[f64; 2]>,
    goal: [f64; 2],
    progress: usize,
    scale: f64,
    nominal: f64,
    half: [f64; 2],
    goal_radius: f64,
    togo: CostToGo,
    /// Local goal on the path and its distance at the current decision.
    local: ([f64; 2], f64),
    /// The planner's model of the vehicle, replaying its own actions (see the module docs).
    shadow: Option<Simulation>,
    /// The simulation every rollout runs in (state copied from the shadow).
    rollout: Option<Simulation>,
    steps_per_control: u64,
    /// Last action sent; the shadow applies it before the next decision.
    last: Option<Action>,
    integral: f64,
    /// Current plan: (steering, speed factor) at each knot.
    plan: [[f64; 2]; KNOTS],
    samples: Vec<[[f64; 2]; KNOTS]>,
    costs: Vec<f64>,
    since_replan: usize,
    rng: ChaCha8Rng,
    /// Decisions taken and rollout physics steps simulated (for cost measurements).
    pub decisions: u64,
    pub rollout_steps: u64,
}

impl Default for Mppi6 {
    fn default() -> Self {
        Self::new()
    }
}

impl Mppi6 {
    pub fn new() -> Self {
        Self::with_config(Mppi6Config::default())
    }

    pub fn with_config(cfg: Mppi6Config) -> Self {
        let k = cfg.samples.max(1);
        Mppi6 {
            cfg,
            path: Vec::new(),
            goal: [0.0; 2],
            progress: 0,
            scale: 1.0,
            nominal: 1.0,
            half: [0.0; 2],
            goal_radius: 10.0,
            togo: CostToGo::default(),
            local: ([0.0; 2], 1.0),
            shadow: None,
            rollout: None,
            steps_per_control: 1,
            last: None,
            integral: 0.0,
            plan: [[0.0, 1.0]; KNOTS],
            samples: vec![[[0.0; 2]; KNOTS]; k],
            costs: vec![0.0; k],
            since_replan: 0,
            rng: ChaCha8Rng::seed_from_u64(0),
            decisions: 0,
            rollout_steps: 0,
        }
    }

    /// Horizon at this episode's scale, s.
    fn horizon(&self) -> f64 {
        self.cfg.horizon * self.scale.sqrt()
    }

    fn knot_spacing(&self) -> f64 {
        self.horizon() / (KNOTS - 1) as f64
    }

    /// Control steps in one rollout.
    fn rollout_controls(&self) -> usize {
        (self.horizon() * RATE).round().max(1.0) as usize
    }

    /// Scores one control sequence from the shadow's state; returns the cost.
    fn rollout_cost(&mut self, k: usize) -> Result<f64, PlannerError> {
        let soil_radius = 2.0 * self.nominal * self.horizon() + 10.0 * self.scale;
        let knots = self.samples[k];
        let n = self.rollout_controls();
        let period = 1.0 / RATE;
        let spacing = self.knot_spacing();
        let (Some(shadow), Some(mut sim)) = (self.shadow.as_ref(), self.rollout.take()) else {
            return Err(PlannerError::Other("act before reset".into()));
        };
        let copied = sim.set_dynamics(shadow.dynamics(), soil_radius);
        let cost = copied.map(|()| self.score(&mut sim, &knots, n, period, spacing));
        self.rollout = Some(sim);
        cost.map_err(|e| PlannerError::Other(e.to_string()))
    }

    /// Runs one rollout of `knots` in `sim` and returns its cost.
    fn score(
        &mut self,
        sim: &mut Simulation,
        knots: &[[f64; 2]; KNOTS],
        n: usize,
        period: f64,
        spacing: f64,
    ) -> f64 {
        let (local_goal, d0) = self.local;
        let mut integral = self.integral;
        let mut cost = 0.0;
        let (p0, reach) = (sim.position(), self.nominal * self.horizon());
        let togo0 = self.togo.at(p0.x, p0.y);
        for c in 0..n {
            let [steer, speed] = interp(knots, c as f64 * period, spacing);
            let s = sim.state();
            let (action, i) = speed_control(
                s.speed,
                speed * self.nominal,
                integral,
                self.nominal,
                steer,
                RATE,
            );
            integral = i;
            let mut contact = false;
            for _ in 0..self.steps_per_control {
                contact |= sim.step(&action).obstacle_contact;
            }
            self.rollout_steps += self.steps_per_control;
            let s = sim.state();
            let [x, y] = [s.position[0], s.position[1]];
            let roll = s.roll.to_degrees().abs();
            if roll > ROLLOVER_DEG
                || !(x.is_finite() && y.is_finite())
                || x.abs() > self.half[0]
                || y.abs() > self.half[1]
            {
                cost += 200.0;
                break;
            }
            if (x - self.goal[0]).hypot(y - self.goal[1]) < self.goal_radius {
                // The remaining steps count as spent at the goal (cost-to-go 0), so arriving early is never worse
                // than driving on.
                cost += (n - c - 1) as f64 / n as f64 * 10.0 * (0.0 - togo0) / reach;
                break;
            }
            let d = (x - local_goal[0]).hypot(y - local_goal[1]) / d0;
            // Progress toward the goal around obstacles, in horizons' worth of nominal driving (negative: ahead).
            let progress = (self.togo.at(x, y) - togo0) / reach;
            cost += step_cost(progress, d, roll, s.pitch.to_degrees()) / n as f64;
            if contact {
                cost += 100.0;
                break;
            }
        }
        cost
    }

    fn replan(&mut self, obs: &Observation) -> Result<(), PlannerError> {
        let s = &obs.state;
        let (local_goal, progress) = point_ahead(
            &self.path,
            [s.position[0], s.position[1]],
            self.progress,
            10.0 * self.scale,
        );
        self.progress = progress;
        let d0 = (local_goal[0] - s.position[0])
            .hypot(local_goal[1] - s.position[1])
            .max(1.0 * self.scale);
        self.local = (local_goal, d0);
        // Warm start: the previous plan shifted by the time since it was made.
        let shift = self.since_replan as f64 / RATE;
        let spacing = self.knot_spacing();
        let old = self.plan;
        for (j, p) in self.plan.iter_mut().enumerate() {
            *p = interp(&old, j as f64 * spacing + shift, spacing);
        }
        let ns = Normal::new(0.0, self.cfg.sigma_steer)
            .map_err(|e| PlannerError::Other(e.to_string()))?;
        let nv = Normal::new(0.0, self.cfg.sigma_speed)
            .map_err(|e| PlannerError::Other(e.to_string()))?;
        for k in 0..self.samples.len() {
            for j in 0..KNOTS {
                let (es, ev) = (ns.sample(&mut self.rng), nv.sample(&mut self.rng));
                self.samples[k][j] = match k {
                    // The warm start itself, hard left and right at a slower speed, and backing up straight.
                    0 => self.plan[j],
                    1 => [1.0, 0.6],
                    2 => [-1.0, 0.6],
                    3 => [0.0, SPEED_MIN],
                    _ => [
                        (self.plan[j][0] + es).clamp(-1.0, 1.0),
                        (self.plan[j][1] + ev).clamp(SPEED_MIN, SPEED_MAX),
                    ],
                };
            }
        }
        for k in 0..self.samples.len() {
            self.costs[k] = self.rollout_cost(k)?;
        }
        self.plan = softmin_plan(&self.costs, &self.samples);
        self.since_replan = 0;
        self.decisions += 1;
        Ok(())
    }
}

impl Planner for Mppi6 {
    fn name(&self) -> &str {
        "mppi6-oracle"
    }
    fn control_rate_hz(&self) -> f64 {
        RATE
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.path = ctx.task.path.clone();
        self.goal = ctx.task.goal;
        self.progress = 0;
        self.scale = ctx.world.scale;
        self.nominal = ctx.vehicle.nominal_speed;
        self.half = [ctx.world.heightmap.half_x(), ctx.world.heightmap.half_y()];
        // The paper's goal radius, scaled with the world (the episode's own rule may differ; this is a cost term).
        self.goal_radius = 10.0 * self.scale;
        self.togo = CostToGo::new(ctx, self.goal);
        let (x, y, yaw) = start_pose(ctx.task);
        let shadow = Simulation::new(ctx.world, ctx.spec, x, y, yaw);
        self.steps_per_control = control_every(RATE, ctx.sim_dt);
        self.rollout = Some(shadow.clone());
        self.shadow = Some(shadow);
        self.last = None;
        self.integral = 0.0;
        self.plan = [[0.0, 1.0]; KNOTS];
        self.since_replan = 0;
        self.rng =
            ChaCha8Rng::seed_from_u64(((ctx.task.world_id as u64) << 8) | ctx.task.index as u64);
        self.decisions = 0;
        self.rollout_steps = 0;
        Ok(())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let shadow = self
            .shadow
            .as_mut()
            .ok_or_else(|| PlannerError::Other("act before reset".into()))?;
        if let Some(a) = self.last {
            for _ in 0..self.steps_per_control {
                shadow.step(&a);
            }
        }
        shadow.set_chassis_state(&obs.state);
        if self.last.is_none() || self.since_replan >= self.cfg.replan_every {
            self.replan(obs)?;
        }
        let [steer, speed] = interp(
            &self.plan,
            self.since_replan as f64 / RATE,
            self.knot_spacing(),
        );
        let (a, integral) = speed_control(
            obs.state.speed,
            speed * self.nominal,
            self.integral,
            self.nominal,
            steer,
            RATE,
        );
        self.integral = integral;
        self.since_replan += 1;
        self.last = Some(a);
        Ok(a)
    }
}
