//! [`KinoMppi`]: MPPI-6 with a learned 6-DoF model (`mppi6`; Lee et al., RA-L 2023): the same sampling planner as
//! the oracle `mppi6-oracle` (`baselines::mppi6`: knots of steering and speed factor around the warm-started plan,
//! the same speed controller, cost-to-go, per-step cost and softmin update), but every sample is rolled out by a
//! learned model ([`Dynamics`]: the crop model, or for `tal` the terrain-attentive one, whose map is taken once per
//! decision) instead of our simulator, and the cost adds the ensemble's disagreement, as Lee et al.'s
//! uncertainty-aware cost does.
//!
//! A decision every model step ([`STEP_FRAMES`] control periods): `samples` sequences over `horizon_steps` model
//! steps. Per sample and step: the knots give the steering and the target speed; the speed controller (at the model
//! step's rate, on the speed the model predicted for the last step) gives throttle and brake; the model's inputs are
//! made from the predicted pose ([`features`](super::features): its crop of the world, or its offset from the
//! decision's map, the ground under it, the previous predicted change of pose); the members' mean moves the pose.
//! Costs per step: `step_cost` (progress on the cost-to-go, local goal, roll and pitch) plus `uncertainty` times the
//! members' summed standard deviation of the six scaled pose changes; entering an obstacle cell (inflated by half
//! the vehicle's width) ends the rollout with 100, a predicted rollover (|roll| > 30 deg) or leaving the map with
//! 200; reaching the goal ends it as in the oracle. With a traversability estimator (`tnt`,
//! [`KinoMppi::with_traversability`]), each step also costs `traversability` times the estimator's weighted channels
//! at the predicted pose ([`TravNet::cost`]: its grid is estimated once per decision from the map at the decision's
//! pose, and the pose is looked up in that map's frame), the release's factor of 3 on its estimator's weighted sum.
//! The model never saw reversing (its datasets drive forwards), so speed factors stay in [0, 1]. With
//! [`Rollout::Decomposed`] (`wmvct`) x, y and yaw come from a kinematic bicycle instead, as WM-VCT decomposes the
//! motion (the release's WMVCT does the same with TAL's network); the cost is the same.
//!
//! Between decisions the plan is executed at 20 Hz with the measured speed, as the oracle does. The noise comes from
//! a generator seeded by the task id: an episode is reproducible and the same at any thread count.

use super::features::{
    apply_delta, ground, previous_delta, vector_features, Pose, Scales, STEP_FRAMES, STEP_S,
    TARGETS,
};
use super::{Dynamics, TravNet};
use mppi_core::{interp, softmin_plan, speed_control, step_cost, CostToGo, KNOTS, ROLLOVER_DEG};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sim_core::control::point_ahead;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::runner::control_every;
use sim_core::world::World;

/// Rate of `act`, Hz.
const RATE: f64 = 20.0;

/// What rolls a sample out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rollout {
    /// The learned model, all six degrees of freedom (`mppi6`).
    Learned,
    /// WM-VCT's decomposition (`wmvct`): a kinematic bicycle (the vehicle's wheelbase and steering range, at the
    /// commanded speed) for x, y and yaw, the learned model for z, roll and pitch.
    Decomposed,
}

/// Tunable parameters of [`KinoMppi`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KinoMppiConfig {
    /// Samples per decision.
    pub samples: usize,
    /// Model steps per rollout.
    pub horizon_steps: usize,
    /// Noise standard deviations of the steering and speed-factor knots.
    pub sigma_steer: f64,
    pub sigma_speed: f64,
    /// Weight of the ensemble's disagreement per step.
    pub uncertainty: f64,
    /// Weight of the traversability estimator's cost per step (only with an estimator).
    pub traversability: f64,
    pub rollout: Rollout,
}

impl Default for KinoMppiConfig {
    fn default() -> Self {
        KinoMppiConfig {
            samples: 64,
            horizon_steps: 8,
            sigma_steer: 0.45,
            sigma_speed: 0.35,
            uncertainty: 1.0,
            traversability: 3.0,
            rollout: Rollout::Learned,
        }
    }
}

/// One rollout's state.
#[derive(Clone, Copy, Debug, Default)]
struct Roll {
    pose: Pose,
    prev: [f64; 6],
    steering: f64,
    integral: f64,
    cost: f64,
    done: bool,
}

#[derive(Clone, Debug)]
struct Episode {
    world: World,
    path: Vec<[f64; 2]>,
    goal: [f64; 2],
    progress: usize,
    scales: Scales,
    /// A model step's real duration (the control period is a whole number of physics steps), s.
    step_s: f64,
    /// The bicycle of [`Rollout::Decomposed`]: wheelbase (m) and largest steering angle (rad).
    wheelbase: f64,
    max_steer: f64,
    half: [f64; 2],
    goal_radius: f64,
    togo: CostToGo,
    blocked: Vec<bool>,
    grid: (usize, usize, f64),
    /// The pose at the previous decision (one model step ago).
    last_pose: Option<Pose>,
    rng: ChaCha8Rng,
}

/// MPPI-6 with a learned kinodynamic model.
#[derive(Clone, Debug)]
pub struct KinoMppi {
    name: String,
    cfg: KinoMppiConfig,
    model: Dynamics,
    trav: Option<TravNet>,
    ep: Option<Episode>,
    plan: [[f64; 2]; KNOTS],
    samples: Vec<[[f64; 2]; KNOTS]>,
    rolls: Vec<Roll>,
    costs: Vec<f64>,
    out: Vec<f32>,
    since_replan: usize,
    integral: f64,
    /// Decisions taken and model predictions made (for cost measurements).
    pub decisions: u64,
    pub predictions: u64,
}

impl KinoMppi {
    /// The planner `name` rolling out `model`.
    pub fn new(name: &str, model: impl Into<Dynamics>, cfg: KinoMppiConfig) -> KinoMppi {
        let model = model.into();
        let k = cfg.samples.max(1);
        let out = vec![0.0; model.members() * TARGETS.len()];
        KinoMppi {
            name: name.to_string(),
            cfg,
            model,
            trav: None,
            ep: None,
            plan: [[0.0, 1.0]; KNOTS],
            samples: vec![[[0.0; 2]; KNOTS]; k],
            rolls: vec![Roll::default(); k],
            costs: vec![0.0; k],
            out,
            since_replan: 0,
            integral: 0.0,
            decisions: 0,
            predictions: 0,
        }
    }

    /// The planner that also charges each rollout step the estimator's traversability cost (`tnt`).
    pub fn with_traversability(mut self, estimator: TravNet) -> KinoMppi {
        self.trav = Some(estimator);
        self
    }

    fn knot_spacing(&self) -> f64 {
        self.cfg.horizon_steps as f64 * STEP_S / (KNOTS - 1) as f64
    }

    /// One MPPI decision: the warm-started plan, the samples, every rollout through the learned model step by step
    /// with its cost, and the softmin plan. One piece on purpose: the rollout loop holds the model, its output
    /// buffer and the rollouts borrowed at once, and the cost's terms (progress, path distance, attitude, spread,
    /// traversability, the terminal checks) are the planner's definition, read together.
    fn replan(&mut self, obs: &Observation) -> Result<(), PlannerError> {
        let spacing = self.knot_spacing();
        let Some(ep) = self.ep.as_mut() else {
            return Err(PlannerError::Other("act before reset".into()));
        };
        let s = &obs.state;
        let now: Pose = [
            s.position[0],
            s.position[1],
            s.position[2],
            s.roll,
            s.pitch,
            s.yaw,
        ];
        let before = ep.last_pose.unwrap_or(now);
        ep.last_pose = Some(now);
        let (local, progress) = point_ahead(
            &ep.path,
            [now[0], now[1]],
            ep.progress,
            10.0 * ep.scales.scale,
        );
        ep.progress = progress;
        let d0 = (local[0] - now[0])
            .hypot(local[1] - now[1])
            .max(ep.scales.scale);
        // Warm start: the plan shifted by one model step.
        let old = self.plan;
        for (j, p) in self.plan.iter_mut().enumerate() {
            *p = interp(&old, j as f64 * spacing + STEP_S, spacing);
        }
        let err = |e: rand_distr::NormalError| PlannerError::Other(e.to_string());
        let ns = Normal::new(0.0, self.cfg.sigma_steer).map_err(err)?;
        let nv = Normal::new(0.0, self.cfg.sigma_speed).map_err(err)?;
        draw_samples(&mut self.samples, &self.plan, (ns, nv), &mut ep.rng);
        let prev = previous_delta(&before, &now);
        self.rolls.fill(Roll {
            pose: now,
            prev,
            steering: s.steering,
            integral: self.integral,
            cost: 0.0,
            done: false,
        });
        let n = self.cfg.horizon_steps.max(1);
        let togo0 = ep.togo.at(now[0], now[1]);
        let reach = ep.scales.nominal_speed * n as f64 * STEP_S;
        let factors = ep.scales.target_factors();
        let members = self.model.members();
        self.model.begin(&ep.world, &now, ep.scales.scale);
        if let Some(t) = self.trav.as_mut() {
            t.set_anchor(&ep.world, &now, ep.scales.scale);
        }
        let t_n = TARGETS.len();
        for t in 0..n {
            for k in 0..self.rolls.len() {
                let r = &mut self.rolls[k];
                if r.done {
                    continue;
                }
                let [steer, speed] = interp(&self.samples[k], t as f64 * STEP_S, spacing);
                let v = r.prev[0] / ep.step_s;
                let nominal = ep.scales.nominal_speed;
                let (a, integral) = speed_control(
                    v,
                    speed * nominal,
                    r.integral,
                    nominal,
                    steer,
                    1.0 / ep.step_s,
                );
                r.integral = integral;
                let g = ground(&ep.world, r.pose[0], r.pose[1]);
                let vector = vector_features(
                    &r.prev,
                    &r.pose,
                    r.steering,
                    &[a.steering, a.throttle, a.brake],
                    &g,
                    &ep.scales,
                );
                self.model
                    .predict(&ep.world, &r.pose, ep.scales.scale, &vector, &mut self.out);
                self.predictions += 1;
                let (mean, spread) = ensemble(&self.out, members, t_n);
                let mut delta: [f64; 6] = std::array::from_fn(|j| mean[j] * factors[j]);
                r.steering = mean[6].clamp(-1.0, 1.0);
                if self.cfg.rollout == Rollout::Decomposed {
                    // The bicycle at the commanded speed and steering: the arc's chord and its turn.
                    let v = speed * nominal;
                    let turn = v / ep.wheelbase * (a.steering * ep.max_steer).tan() * ep.step_s;
                    let chord = v * ep.step_s;
                    delta[0] = chord * (0.5 * turn).cos();
                    delta[1] = chord * (0.5 * turn).sin();
                    delta[5] = turn;
                    r.steering = a.steering;
                }
                let next = apply_delta(&r.pose, &delta);
                r.prev = previous_delta(&r.pose, &next);
                r.pose = next;
                let (x, y) = (next[0], next[1]);
                let roll = next[3].to_degrees().abs();
                if roll > ROLLOVER_DEG
                    || !(x.is_finite() && y.is_finite())
                    || x.abs() > ep.half[0]
                    || y.abs() > ep.half[1]
                {
                    r.cost += 200.0;
                    r.done = true;
                    continue;
                }
                if (x - ep.goal[0]).hypot(y - ep.goal[1]) < ep.goal_radius {
                    r.cost += (n - t - 1) as f64 / n as f64 * 10.0 * (0.0 - togo0) / reach;
                    r.done = true;
                    continue;
                }
                let d = (x - local[0]).hypot(y - local[1]) / d0;
                let progress = (ep.togo.at(x, y) - togo0) / reach;
                let trav = self
                    .trav
                    .as_ref()
                    .map_or(0.0, |t| self.cfg.traversability * t.cost(&next));
                r.cost += (step_cost(progress, d, roll, next[4].to_degrees())
                    + self.cfg.uncertainty * spread
                    + trav)
                    / n as f64;
                if blocked_at(&ep.blocked, ep.grid, x, y) {
                    r.cost += 100.0;
                    r.done = true;
                }
            }
        }
        for (c, r) in self.costs.iter_mut().zip(&self.rolls) {
            *c = r.cost;
        }
        self.plan = softmin_plan(&self.costs, &self.samples);
        self.since_replan = 0;
        self.decisions += 1;
        Ok(())
    }
}

/// The ensemble's mean prediction of members' outputs `out` (`t_n` targets each) and its spread: the sum over the
/// six motion targets of the members' standard deviations.
fn ensemble(out: &[f32], members: usize, t_n: usize) -> ([f64; 7], f64) {
    let mut mean = [0.0f64; 7];
    for m in 0..members {
        for (j, x) in mean.iter_mut().enumerate() {
            *x += f64::from(out[m * t_n + j]);
        }
    }
    mean.iter_mut().for_each(|x| *x /= members as f64);
    let mut spread = 0.0;
    for (j, &mu) in mean.iter().enumerate().take(6) {
        let var = (0..members)
            .map(|m| (f64::from(out[m * t_n + j]) - mu).powi(2))
            .sum::<f64>()
            / members as f64;
        spread += var.sqrt();
    }
    (mean, spread)
}

/// The rollouts' control knots: the warm-started plan, full left and full right at 0.6, and the plan perturbed by
/// the steering and speed noises `(ns, nv)` (both drawn for every knot of every sample, in order, so the stream
/// stays the same whichever sample uses them).
fn draw_samples(
    samples: &mut [[[f64; 2]; KNOTS]],
    plan: &[[f64; 2]; KNOTS],
    (ns, nv): (Normal<f64>, Normal<f64>),
    rng: &mut ChaCha8Rng,
) {
    for (k, sample) in samples.iter_mut().enumerate() {
        for (j, knot) in sample.iter_mut().enumerate() {
            let (es, ev) = (ns.sample(rng), nv.sample(rng));
            *knot = match k {
                0 => plan[j],
                1 => [1.0, 0.6],
                2 => [-1.0, 0.6],
                _ => [
                    (plan[j][0] + es).clamp(-1.0, 1.0),
                    (plan[j][1] + ev).clamp(0.0, 1.0),
                ],
            };
        }
    }
}

fn blocked_at(blocked: &[bool], (nx, ny, cell): (usize, usize, f64), x: f64, y: f64) -> bool {
    let fx = (x / cell + (nx as f64 - 1.0) / 2.0).round();
    let fy = (y / cell + (ny as f64 - 1.0) / 2.0).round();
    if fx < 0.0 || fy < 0.0 || fx > (nx - 1) as f64 || fy > (ny - 1) as f64 {
        return true;
    }
    blocked[fy as usize * nx + fx as usize]
}

impl Planner for KinoMppi {
    fn name(&self) -> &str {
        &self.name
    }
    fn control_rate_hz(&self) -> f64 {
        RATE
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        if let Some(trained) = self.model.metadata().get("vehicle") {
            if trained != &ctx.vehicle.name {
                return Err(PlannerError::Other(format!(
                    "model of `{}` was trained for the {trained}; this episode's vehicle is the {}",
                    self.name, ctx.vehicle.name
                )));
            }
        }
        let h = &ctx.world.heightmap;
        let scale = ctx.world.scale;
        self.ep = Some(Episode {
            world: ctx.world.clone(),
            path: ctx.task.path.clone(),
            goal: ctx.task.goal,
            progress: 0,
            scales: Scales {
                scale,
                nominal_speed: ctx.vehicle.nominal_speed,
            },
            step_s: STEP_FRAMES as f64 * control_every(RATE, ctx.sim_dt) as f64 * ctx.sim_dt,
            wheelbase: ctx.vehicle.wheelbase.max(1e-3),
            max_steer: ctx.vehicle.max_steer,
            half: [h.half_x(), h.half_y()],
            goal_radius: 10.0 * scale,
            togo: CostToGo::new(ctx, ctx.task.goal),
            blocked: mppi_core::inflated_obstacles(ctx.world, 0.5 * ctx.vehicle.width),
            grid: (h.nx, h.ny, h.cell),
            last_pose: None,
            rng: ChaCha8Rng::seed_from_u64(
                ((ctx.task.world_id as u64) << 8) | ctx.task.index as u64,
            ),
        });
        self.plan = [[0.0, 1.0]; KNOTS];
        self.since_replan = 0;
        self.integral = 0.0;
        self.decisions = 0;
        self.predictions = 0;
        Ok(())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        if self.decisions == 0 || self.since_replan >= STEP_FRAMES {
            self.replan(obs)?;
        }
        let [steer, speed] = interp(
            &self.plan,
            self.since_replan as f64 / RATE,
            self.knot_spacing(),
        );
        let nominal = self.ep.as_ref().map_or(1.0, |e| e.scales.nominal_speed);
        let (a, integral) = speed_control(
            obs.state.speed,
            speed * nominal,
            self.integral,
            nominal,
            steer,
            RATE,
        );
        self.integral = integral;
        self.since_replan += 1;
        Ok(a)
    }
}
