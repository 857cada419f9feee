//! MPPI with a kinematic bicycle model (the release's MPPI baseline, adapted to the vehicle's own geometry).
//!
//! Every control step (20 Hz) draws K = 800 steering sequences of T = 20 model steps of 0.1 s around the previous
//! plan (noise sigma 0.5, normalised steering), rolls a bicycle model with the vehicle's wheelbase and maximum
//! steering angle forward at the nominal speed, and scores each rollout with the sum over its steps of
//! `10 * (distance to the local goal / initial distance)^2 + 0.1 * |steering noise| + 50 * (inside an obstacle)`,
//! the local goal being 10 m (scaled) ahead on the path. The new plan is the exponentially weighted mean (lambda = 0.1 on min-max normalised
//! costs). Like the release, only steering comes from MPPI; speed is held by the same PI controller as PID.
//! Obstacles come from the ground-truth occupancy grid, inflated by the vehicle's half width. The noise is drawn from
//! a generator seeded by the task id, so an episode is reproducible.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sim_core::control::point_ahead;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};

const K: usize = 800;
const T: usize = 20;
const MODEL_DT: f64 = 0.1;
const SIGMA: f64 = 0.5;
const LAMBDA: f64 = 0.1;

/// The MPPI baseline.
#[derive(Clone, Debug)]
pub struct Mppi {
    tracker: crate::Tracker,
    plan: [f64; T],
    noise: Vec<f64>,
    costs: Vec<f64>,
    rng: ChaCha8Rng,
    wheelbase: f64,
    max_steer: f64,
    /// Inflated obstacle grid: `blocked[iy * nx + ix]`, with the map geometry.
    blocked: Vec<bool>,
    /// The inflation radius and the believed world `blocked` was made from (under a map-degrading profile).
    inflate: f64,
    seen: Option<std::sync::Arc<sim_core::world::World>>,
    nx: usize,
    ny: usize,
    cell: f64,
}

impl Default for Mppi {
    fn default() -> Self {
        Self::new()
    }
}

impl Mppi {
    pub fn new() -> Self {
        Mppi {
            tracker: crate::Tracker::default(),
            plan: [0.0; T],
            noise: vec![0.0; K * T],
            costs: vec![0.0; K],
            rng: ChaCha8Rng::seed_from_u64(0),
            wheelbase: 1.0,
            max_steer: 0.5,
            blocked: Vec::new(),
            inflate: 0.0,
            seen: None,
            nx: 0,
            ny: 0,
            cell: 1.0,
        }
    }

    fn is_blocked(&self, x: f64, y: f64) -> bool {
        let fx = x / self.cell + (self.nx as f64 - 1.0) / 2.0;
        let fy = y / self.cell + (self.ny as f64 - 1.0) / 2.0;
        if fx < 0.0 || fy < 0.0 || fx > (self.nx - 1) as f64 || fy > (self.ny - 1) as f64 {
            return true;
        }
        self.blocked[fy.round() as usize * self.nx + fx.round() as usize]
    }
}

impl Planner for Mppi {
    fn name(&self) -> &str {
        "mppi"
    }
    fn control_rate_hz(&self) -> f64 {
        crate::Tracker::RATE
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.tracker.reset(ctx);
        self.plan = [0.0; T];
        self.rng =
            ChaCha8Rng::seed_from_u64(((ctx.task.world_id as u64) << 8) | ctx.task.index as u64);
        self.wheelbase = ctx.vehicle.wheelbase.max(1e-3);
        self.max_steer = if ctx.vehicle.skid_steer {
            0.6
        } else {
            ctx.vehicle.max_steer
        };
        let h = &ctx.world.heightmap;
        (self.nx, self.ny, self.cell) = (h.nx, h.ny, h.cell);
        // Inflate by the vehicle's half width.
        self.inflate = 0.5 * ctx.vehicle.width;
        self.blocked = crate::inflated_obstacles(ctx.world, self.inflate);
        self.seen = None;
        Ok(())
    }
    /// Under a map-degrading profile it avoids the obstacles detected so far (it reads no heights).
    fn reads_belief(&self) -> bool {
        true
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        if let Some(b) = crate::believed_obstacles(&mut self.seen, obs, self.inflate) {
            self.blocked = b;
        }
        let s = &obs.state;
        let (goal, progress) = point_ahead(
            &self.tracker.path,
            [s.position[0], s.position[1]],
            self.tracker.progress,
            10.0 * self.tracker.scale,
        );
        self.tracker.progress = progress;
        let normal = Normal::new(0.0, SIGMA).map_err(|e| PlannerError::Other(e.to_string()))?;
        let v = self.tracker.speed.target.max(0.5 * s.speed.abs());
        let d0 = (goal[0] - s.position[0])
            .hypot(goal[1] - s.position[1])
            .max(1e-3);
        for k in 0..K {
            let (mut x, mut y, mut yaw) = (s.position[0], s.position[1], s.yaw);
            let mut cost = 0.0;
            for t in 0..T {
                let e = normal.sample(&mut self.rng);
                self.noise[k * T + t] = e;
                let u = (self.plan[t] + e).clamp(-1.0, 1.0);
                yaw += v / self.wheelbase * (u * self.max_steer).tan() * MODEL_DT;
                x += v * yaw.cos() * MODEL_DT;
                y += v * yaw.sin() * MODEL_DT;
                let d = (goal[0] - x).hypot(goal[1] - y) / d0;
                cost += 10.0 * d * d + 0.1 * e.abs();
                if self.is_blocked(x, y) {
                    cost += 50.0;
                }
            }
            self.costs[k] = cost;
        }
        let lo = self.costs.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.costs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let span = (hi - lo).max(1e-9);
        let mut weights_sum = 0.0;
        let mut update = [0.0; T];
        for k in 0..K {
            let w = (-((self.costs[k] - lo) / span) / LAMBDA).exp();
            weights_sum += w;
            for (t, u) in update.iter_mut().enumerate() {
                *u += w * self.noise[k * T + t];
            }
        }
        for (p, u) in self.plan.iter_mut().zip(update) {
            *p = (*p + u / weights_sum).clamp(-1.0, 1.0);
        }
        let steer = self.plan[0];
        // Receding horizon: the control period (0.05 s) is half a model step, so shift the plan by half a step.
        for t in 0..T - 1 {
            self.plan[t] = 0.5 * (self.plan[t] + self.plan[t + 1]);
        }
        let mut a = self.tracker.act(obs, 0.0);
        a.steering = steer.clamp(-1.0, 1.0);
        self.tracker.steering = a.steering;
        Ok(a)
    }
}
