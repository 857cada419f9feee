//! `mppi-release`: the original release's MPPI as published (`systems/MPPI/MPPI.py`; reference
//! `verti-bench-release.md` section 6), so the paper's MPPI row can be compared like for like. Our [`crate::mppi`]
//! is a better planner (the vehicle's own wheelbase and steering, a warm-started plan shifted by the real control
//! period); this one keeps the release's model, constants and quirks:
//!
//! - 20 Hz, K = 800 samples, T = 20 model steps of one model unit, lambda = 0.1, noise sigma 0.2 on the normalised
//!   speed and 0.5 on the steering; the speed is clamped to [0.45, 0.6] (to [-1, 1] within 2 m of the goal), the
//!   steering to [-1, 1].
//! - Rollouts: a kinematic bicycle of the release's 1/10-scale robot, wheelbase 0.32 model units, forward speed
//!   `v / 0.75` and steering angle `0.6 steer` per model step, unscaled into metres and radians by the release's
//!   `pose_dot` statistics (0.0583 m per unit times its x10 scale-up, 0.0649 rad per unit of yaw) and composed in
//!   SE(2): about 0.35-0.47 m per step, a 7-9 m horizon, and a turning radius near 4 m, far tighter than the
//!   HMMWV's. The release's `utilities.py` (its Ackermann step and SE(2) composition) is not in the public copy we
//!   read; the step here follows the reference's description of it.
//! - Cost per step: `0.5 lambda |u / sigma * noise|` summed over both controls, plus 10 times the squared distance
//!   to the local goal min-max normalised over the samples at that step, plus 50 when the pose's map cell holds an
//!   obstacle (the raw obstacle map, not inflated).
//! - Weights `exp(-(c - min c) / lambda) / sum + 1e-6` (the release adds 1e-6 to every normalised weight); the plan
//!   moves by the weighted sum of the noise; the applied control is the plan's first entry, and the plan is then
//!   rotated by one (`torch.roll`: the applied entry wraps around to the end).
//! - Only the steering is used, unsmoothed; the speed is held at the vehicle's nominal speed by the same PI
//!   controller as PID (the release drives the throttle from its fixed `speed` argument).
//! - Local goal: the first path point, from the last one chosen on, at least 10 m (scaled) away and within 90
//!   degrees of the heading; otherwise the path's last point.
//!
//! The noise is drawn from a generator seeded by the task id, so an episode is reproducible.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};

const K: usize = 800;
const T: usize = 20;
const LAMBDA: f64 = 0.1;
/// Noise standard deviations of (normalised speed, steering).
const SIGMA: [f64; 2] = [0.2, 0.5];
const MIN_VEL: f64 = 0.45;
const MAX_VEL: f64 = 0.6;
/// The release's robot: wheelbase in model units, speed and steering maps.
const WHEELBASE: f64 = 0.32;
const SPEED_DIV: f64 = 0.75;
const STEER_GAIN: f64 = 0.6;
/// Model units to metres (`pose_dot` scale 0.0583 times the x10 scale-up) and to radians of yaw.
const UNIT_M: f64 = 0.0583 * 10.0;
const UNIT_YAW: f64 = 0.0649;

/// One model step of the release's bicycle from `(x, y, yaw)` with normalised speed `v` and steering `steer`.
pub fn release_bicycle_step(pose: [f64; 3], v: f64, steer: f64) -> [f64; 3] {
    let speed = v / SPEED_DIV;
    let dyaw = speed / WHEELBASE * (STEER_GAIN * steer).tan() * UNIT_YAW;
    let ds = speed * UNIT_M;
    let yaw = pose[2] + dyaw;
    let mid = pose[2] + 0.5 * dyaw;
    [pose[0] + ds * mid.cos(), pose[1] + ds * mid.sin(), yaw]
}

/// The release's MPPI baseline.
#[derive(Clone, Debug)]
pub struct MppiRelease {
    tracker: crate::Tracker,
    /// Plan: (normalised speed, steering) per model step.
    plan: [[f64; 2]; T],
    noise: Vec<[f64; 2]>,
    costs: Vec<f64>,
    dist2: Vec<f64>,
    poses: Vec<[f64; 3]>,
    rng: ChaCha8Rng,
    goal_index: usize,
    goal: [f64; 2],
    obstacles: Vec<bool>,
    /// The believed world `obstacles` was made from (under a map-degrading profile).
    seen: Option<std::sync::Arc<sim_core::world::World>>,
    nx: usize,
    ny: usize,
    cell: f64,
}

impl Default for MppiRelease {
    fn default() -> Self {
        Self::new()
    }
}

impl MppiRelease {
    pub fn new() -> Self {
        MppiRelease {
            tracker: crate::Tracker::default(),
            plan: [[0.0; 2]; T],
            noise: vec![[0.0; 2]; K * T],
            costs: vec![0.0; K],
            dist2: vec![0.0; K],
            poses: vec![[0.0; 3]; K],
            rng: ChaCha8Rng::seed_from_u64(0),
            goal_index: 0,
            goal: [0.0; 2],
            obstacles: Vec::new(),
            seen: None,
            nx: 0,
            ny: 0,
            cell: 1.0,
        }
    }

    fn obstacle_at(&self, x: f64, y: f64) -> bool {
        let fx = (x / self.cell + (self.nx as f64 - 1.0) / 2.0).round();
        let fy = (y / self.cell + (self.ny as f64 - 1.0) / 2.0).round();
        // The release clamps the cell into the map.
        let ix = fx.clamp(0.0, (self.nx - 1) as f64) as usize;
        let iy = fy.clamp(0.0, (self.ny - 1) as f64) as usize;
        self.obstacles[iy * self.nx + ix]
    }

    /// The release's local goal: from the last index on, the first path point at least `ahead` m away and within
    /// 90 degrees of the heading, else the last point.
    fn local_goal(&mut self, pos: [f64; 2], yaw: f64, ahead: f64) {
        let path = &self.tracker.path;
        let Some(&last) = path.last() else {
            self.goal = pos;
            return;
        };
        for (i, p) in path.iter().enumerate().skip(self.goal_index) {
            let (dx, dy) = (p[0] - pos[0], p[1] - pos[1]);
            if dx.hypot(dy) >= ahead
                && crate::wrap(dy.atan2(dx) - yaw).abs() <= std::f64::consts::FRAC_PI_2
            {
                self.goal_index = i;
                self.goal = *p;
                return;
            }
        }
        self.goal_index = path.len() - 1;
        self.goal = last;
    }
}

impl Planner for MppiRelease {
    fn name(&self) -> &str {
        "mppi-release"
    }
    fn control_rate_hz(&self) -> f64 {
        crate::Tracker::RATE
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.tracker.reset(ctx);
        self.plan = [[0.0; 2]; T];
        self.goal_index = 0;
        self.rng =
            ChaCha8Rng::seed_from_u64(((ctx.task.world_id as u64) << 8) | ctx.task.index as u64);
        let h = &ctx.world.heightmap;
        (self.nx, self.ny, self.cell) = (h.nx, h.ny, h.cell);
        self.obstacles = crate::inflated_obstacles(ctx.world, 0.0);
        self.seen = None;
        Ok(())
    }
    /// Under a map-degrading profile it avoids the obstacles detected so far (it reads no heights).
    fn reads_belief(&self) -> bool {
        true
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        if let Some(b) = crate::believed_obstacles(&mut self.seen, obs, 0.0) {
            self.obstacles = b;
        }
        let s = &obs.state;
        let pos = [s.position[0], s.position[1]];
        self.local_goal(pos, s.yaw, 10.0 * self.tracker.scale);
        let final_goal = self.tracker.path.last().copied().unwrap_or(pos);
        let near = (final_goal[0] - pos[0]).hypot(final_goal[1] - pos[1]) < 2.0;
        let (lo_v, hi_v) = if near {
            (-1.0, 1.0)
        } else {
            (MIN_VEL, MAX_VEL)
        };
        let normal =
            |sigma| Normal::new(0.0, sigma).map_err(|e| PlannerError::Other(format!("{e}")));
        let (n_speed, n_steer) = (normal(SIGMA[0])?, normal(SIGMA[1])?);
        // Noise in the release's order: T x K x 2.
        for t in 0..T {
            for k in 0..K {
                self.noise[t * K + k] =
                    [n_speed.sample(&mut self.rng), n_steer.sample(&mut self.rng)];
            }
        }
        self.costs.fill(0.0);
        self.poses.fill([pos[0], pos[1], s.yaw]);
        for t in 0..T {
            for k in 0..K {
                let e = self.noise[t * K + k];
                let v = (self.plan[t][0] + e[0]).clamp(lo_v, hi_v);
                let u = (self.plan[t][1] + e[1]).clamp(-1.0, 1.0);
                self.poses[k] = release_bicycle_step(self.poses[k], v, u);
                let p = self.poses[k];
                self.dist2[k] = (p[0] - self.goal[0]).powi(2) + (p[1] - self.goal[1]).powi(2);
                // Control cost: 0.5 lambda |plan / sigma * noise|, per control, on the unclamped plan.
                self.costs[k] += (0..2)
                    .map(|i| (0.5 * LAMBDA * self.plan[t][i] / SIGMA[i] * e[i]).abs())
                    .sum::<f64>();
            }
            let lo = self.dist2.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = self.dist2.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            for k in 0..K {
                let d = (self.dist2[k] - lo) / (hi + 1e-6 - lo);
                let p = self.poses[k];
                let hit = if self.obstacle_at(p[0], p[1]) {
                    50.0
                } else {
                    0.0
                };
                self.costs[k] += 10.0 * d + hit;
            }
        }
        let lo = self.costs.iter().copied().fold(f64::INFINITY, f64::min);
        let mut sum = 0.0;
        for c in &mut self.costs {
            *c = (-(*c - lo) / LAMBDA).exp();
            sum += *c;
        }
        for t in 0..T {
            let mut change = [0.0; 2];
            for k in 0..K {
                let w = self.costs[k] / sum + 1e-6;
                let e = self.noise[t * K + k];
                change[0] += w * e[0];
                change[1] += w * e[1];
            }
            self.plan[t][0] = (self.plan[t][0] + change[0]).clamp(lo_v, hi_v);
            self.plan[t][1] = (self.plan[t][1] + change[1]).clamp(-1.0, 1.0);
        }
        let steer = self.plan[0][1];
        self.plan.rotate_left(1);
        let mut a = self.tracker.act(obs, 0.0);
        a.steering = steer.clamp(-1.0, 1.0);
        self.tracker.steering = a.steering;
        Ok(a)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim_core::planner::VehicleState;
    use sim_core::world::*;

    fn run(path: Vec<[f64; 2]>, pose: [f64; 3], steps: usize) -> (MppiRelease, Action) {
        let w = World::uniform(
            Heightmap::from_fn(1.0, |_, _| 0.0),
            Semantic::Dirt,
            Surface::Rigid { friction: 0.6 },
        );
        let task = Task {
            world_id: 1,
            index: 0,
            start: path[0],
            goal: *path.last().unwrap(),
            path,
        };
        let vehicle = crate::tests::info();
        let mut p = MppiRelease::new();
        p.reset(&PlannerContext {
            world: &w,
            task: &task,
            vehicle: &vehicle,
            spec: &crate::tests::spec(),
            sim_dt: 0.002,
            believed: false,
        })
        .unwrap();
        let obs = Observation {
            state: VehicleState {
                position: [pose[0], pose[1], 0.0],
                yaw: pose[2],
                ..Default::default()
            },
            belief: None,
        };
        let mut a = Action::default();
        for _ in 0..steps {
            a = p.act(&obs).unwrap();
        }
        (p, a)
    }

    #[test]
    fn it_steers_toward_a_local_goal_on_its_left_and_holds_the_nominal_speed() {
        let (_, a) = run(vec![[0.0, 0.0], [0.0, 30.0]], [0.0, 0.0, 0.0], 3);
        assert!(a.steering > 0.3, "goal 90 degrees left: {a:?}");
        assert!(
            a.throttle > 0.9 && a.brake == 0.0,
            "standing: full throttle (PI to 4 m/s): {a:?}"
        );
        let (_, a) = run(vec![[0.0, 0.0], [0.0, -30.0]], [0.0, 0.0, 0.0], 3);
        assert!(a.steering < -0.3, "goal on the right: {a:?}");
    }

    #[test]
    fn its_local_goal_is_the_first_path_point_ten_metres_away_and_ahead() {
        let path: Vec<[f64; 2]> = (1..=12).map(|i| [5.0 * i as f64, 0.0]).collect();
        // From x = 12 facing +x: (20, 0) is 8 m away, (25, 0) the first at >= 10 m.
        let (p, _) = run(path.clone(), [12.0, 0.0, 0.0], 1);
        assert_eq!(p.goal, [25.0, 0.0]);
        // Facing -x every point at least 10 m away lies behind: the path's last point.
        let (p, _) = run(path, [12.0, 0.0, std::f64::consts::PI], 1);
        assert_eq!(p.goal, [60.0, 0.0]);
    }

    #[test]
    fn the_release_bicycle_turns_far_tighter_than_the_hmmwv() {
        // Straight: 0.6 / 0.75 units of 0.583 m per step.
        let p = release_bicycle_step([0.0, 0.0, 0.0], 0.6, 0.0);
        assert!((p[0] - 0.8 * UNIT_M).abs() < 1e-12 && p[1] == 0.0 && p[2] == 0.0);
        // Full left: radius = step length / yaw change = 0.32 x 0.583 / (tan 0.6 x 0.0649) = 4.20 m, whatever the
        // speed (the HMMWV's own: 3.378 m / tan(max steer), over 6 m).
        let p = release_bicycle_step([0.0, 0.0, 0.0], 0.6, 1.0);
        let radius = 0.8 * UNIT_M / p[2];
        assert!((radius - 4.20).abs() < 0.01, "radius {radius}");
        assert!(p[1] > 0.0, "positive steering turns left");
    }
}
