//! Baseline mobility systems, written against `sim_core::planner::Planner`. They read only what a real system
//! could be given: ground-truth state, the global path and the ground-truth maps.
//!
//! - [`Pid`]: local goal 10 m (scaled) ahead on the global path, heading P control with a steering rate limit,
//!   PI speed control to the vehicle's nominal speed (the release's PID at 20 Hz instead of 200 Hz).
//! - [`ElevationHeuristic`]: the same, with the heading mixed (0.2 / 0.8) between the path and the flattest of
//!   five regions ahead, i.e. the one whose mean height is closest to the mean under the vehicle (ties: lower
//!   variance), as the release's EH.
//!
//! - [`mppi::Mppi`]: MPPI with a kinematic bicycle model.
//! - [`mppi_release::MppiRelease`]: the original release's MPPI as published (its small robot's bicycle model,
//!   steering only), for like-for-like comparison with the paper's MPPI row.
//! - [`mppi6::Mppi6`] (`mppi6-oracle`): MPPI-6 whose rollouts run our own 6-DoF simulator on a copy of the world
//!   (an *oracle* model: the benchmark's own vehicle model; the learned `mppi6` in `planners/learned` rolls out a
//!   learned model with the same planner, and this is its upper bound).

pub mod mppi;
pub mod mppi6;
pub mod mppi_release;

/// The MPPI-6 pieces every MPPI planner shares (the `mppi-core` crate).
pub use mppi_core as hybrid;
pub use mppi_core::inflated_obstacles;

use sim_core::control::point_ahead;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::world::World;
use std::sync::Arc;

/// Under a perception profile that degrades the maps: the obstacle grid of the believed world inflated by `radius`
/// when the belief changed since `seen` (after each of the layer's scans; obstacles not detected yet are free);
/// `None` when it did not, and always under ground truth. The MPPI baselines read no heights, only obstacles.
pub(crate) fn believed_obstacles(
    seen: &mut Option<Arc<World>>,
    obs: &Observation,
    radius: f64,
) -> Option<Vec<bool>> {
    let b = obs.belief.as_ref()?;
    if seen.as_ref().is_some_and(|s| Arc::ptr_eq(s, b)) {
        return None;
    }
    *seen = Some(b.clone());
    Some(inflated_obstacles(b, radius))
}

/// Names of the built-in planners.
pub const NAMES: [&str; 5] = ["pid", "eh", "mppi", "mppi6-oracle", "mppi-release"];

/// A built-in planner by name.
pub fn by_name(name: &str) -> Option<Box<dyn Planner>> {
    match name {
        "pid" => Some(Box::new(Pid::new())),
        "eh" => Some(Box::new(ElevationHeuristic::new())),
        "mppi" => Some(Box::new(mppi::Mppi::new())),
        "mppi6-oracle" => Some(Box::new(mppi6::Mppi6::new())),
        "mppi-release" => Some(Box::new(mppi_release::MppiRelease::new())),
        _ => None,
    }
}

fn wrap(a: f64) -> f64 {
    a.sin().atan2(a.cos())
}

/// The baselines' speed loop: PI control of the forward speed to a target, normalised by the target, to throttle
/// (positive output) or brake at half strength (negative output). Called once per control step at `rate_hz`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SpeedControl {
    /// Target speed, m/s.
    pub target: f64,
    rate_hz: f64,
    integral: f64,
}

impl SpeedControl {
    /// A loop to `target` m/s, called at `rate_hz`, with no integral yet.
    pub fn new(target: f64, rate_hz: f64) -> Self {
        SpeedControl {
            target,
            rate_hz,
            integral: 0.0,
        }
    }

    /// Throttle and brake for the measured forward speed `speed` (m/s): P gain 1, I gain 0.3 (integral clamped to
    /// +-2 m), both per m/s of target.
    pub fn command(&mut self, speed: f64) -> (f64, f64) {
        let err = self.target - speed;
        self.integral = (self.integral + err / self.rate_hz).clamp(-2.0, 2.0);
        let u = (1.0 * err + 0.3 * self.integral) / self.target.max(1e-6);
        (u.clamp(0.0, 1.0), (-u).clamp(0.0, 1.0) * 0.5)
    }
}

/// Shared path-tracking and speed-control state.
#[derive(Clone, Debug, Default)]
struct Tracker {
    path: Vec<[f64; 2]>,
    progress: usize,
    scale: f64,
    speed: SpeedControl,
    steering: f64,
    skid: bool,
}

impl Tracker {
    const RATE: f64 = 20.0;

    fn reset(&mut self, ctx: &PlannerContext<'_>) {
        self.path = ctx.task.path.clone();
        self.progress = 0;
        self.scale = ctx.world.scale;
        self.speed = SpeedControl::new(ctx.vehicle.nominal_speed, Self::RATE);
        self.steering = 0.0;
        self.skid = ctx.vehicle.skid_steer;
    }

    /// Heading error to the local goal 10 m (scaled) ahead on the path.
    fn path_error(&mut self, obs: &Observation) -> f64 {
        let s = &obs.state;
        let (goal, progress) = point_ahead(
            &self.path,
            [s.position[0], s.position[1]],
            self.progress,
            10.0 * self.scale,
        );
        self.progress = progress;
        wrap((goal[1] - s.position[1]).atan2(goal[0] - s.position[0]) - s.yaw)
    }

    /// Steering from a heading error (P gain 1.0 per rad, rate limited to 0.5 per control step) and speed control.
    fn act(&mut self, obs: &Observation, heading_error: f64) -> Action {
        let target = heading_error.clamp(-1.0, 1.0);
        self.steering += (target - self.steering).clamp(-0.5, 0.5);
        let (throttle, brake) = self.speed.command(obs.state.speed);
        Action {
            steering: self.steering,
            throttle,
            brake,
        }
    }
}

/// The PID baseline.
#[derive(Clone, Debug, Default)]
pub struct Pid {
    t: Tracker,
}

impl Pid {
    pub fn new() -> Self {
        Self::default()
    }
}

impl Planner for Pid {
    fn name(&self) -> &str {
        "pid"
    }
    fn control_rate_hz(&self) -> f64 {
        Tracker::RATE
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.t.reset(ctx);
        Ok(())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let e = self.t.path_error(obs);
        Ok(self.t.act(obs, e))
    }
    fn reads_world_maps(&self) -> bool {
        false
    }
}

/// The elevation-heuristics baseline.
#[derive(Clone, Debug, Default)]
pub struct ElevationHeuristic {
    t: Tracker,
    world: Option<World>,
}

impl ElevationHeuristic {
    pub fn new() -> Self {
        Self::default()
    }

    /// Mean and variance of the heights in a square region of side `side` centred at `(x, y)` (5 x 5 samples),
    /// over the samples that are known (a perceived map's unseen cells read `NaN`); `None` when none is.
    fn region(world: &World, x: f64, y: f64, side: f64) -> Option<(f64, f64)> {
        let (mut s, mut s2, mut n) = (0.0, 0.0, 0u32);
        for i in 0..5 {
            for j in 0..5 {
                let h = world.heightmap.height_bilinear(
                    x + side * (i as f64 / 4.0 - 0.5),
                    y + side * (j as f64 / 4.0 - 0.5),
                );
                if h.is_finite() {
                    s += h;
                    s2 += h * h;
                    n += 1;
                }
            }
        }
        if n == 0 {
            return None;
        }
        let m = s / f64::from(n);
        Some((m, s2 / f64::from(n) - m * m))
    }
}

impl Planner for ElevationHeuristic {
    fn name(&self) -> &str {
        "eh"
    }
    fn control_rate_hz(&self) -> f64 {
        Tracker::RATE
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.t.reset(ctx);
        self.world = Some(ctx.world.clone());
        Ok(())
    }
    /// Under a perception profile it reads the believed map: a region is judged by its seen samples, a region
    /// not seen at all is never chosen, and with nothing seen around it follows the path.
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let path_error = self.t.path_error(obs);
        let world = match (&obs.belief, &self.world) {
            (Some(b), _) => b.as_ref(),
            (None, Some(w)) => w,
            (None, None) => return Err(PlannerError::Other("act before reset".into())),
        };
        let s = &obs.state;
        let side = 6.4 * world.scale;
        let Some((here, _)) = Self::region(world, s.position[0], s.position[1], side) else {
            return Ok(self.t.act(obs, path_error));
        };
        // Five regions 6.4 m ahead at -60, -30, 0, 30, 60 degrees from the heading.
        let mut best = (f64::INFINITY, f64::INFINITY, 0.0);
        // Straight ahead first, so ties keep the heading.
        for k in [0, -1, 1, -2, 2] {
            let a = s.yaw + k as f64 * 30f64.to_radians();
            let Some((m, v)) = Self::region(
                world,
                s.position[0] + side * a.cos(),
                s.position[1] + side * a.sin(),
                side,
            ) else {
                continue;
            };
            let d = (m - here).abs();
            if d < best.0 - 1e-9 || ((d - best.0).abs() <= 1e-9 && v < best.1) {
                best = (d, v, k as f64 * 30f64.to_radians());
            }
        }
        Ok(self.t.act(obs, 0.2 * best.2 + 0.8 * path_error))
    }
    fn reads_belief(&self) -> bool {
        true
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use sim_core::planner::{VehicleInfo, VehicleState};
    use sim_core::world::*;

    /// Flat, or with a 1 m mound of radius 3 m centred 6.4 m ahead of the origin.
    fn world(mound: bool) -> World {
        let h = Heightmap::from_fn(1.0, |x, y| {
            if mound && (x - 6.4).hypot(y) < 3.0 {
                1.0
            } else {
                0.0
            }
        });
        World::uniform(h, Semantic::Dirt, Surface::Rigid { friction: 0.6 })
    }

    pub(crate) fn spec() -> sim_core::VehicleSpec {
        sim_core::vehicle::vehicle_by_name("hmmwv").unwrap()
    }

    /// A 3 m-wheelbase car at 4 m/s nominal.
    pub(crate) fn info() -> VehicleInfo {
        VehicleInfo {
            name: "t".into(),
            scale: 1.0,
            wheelbase: 3.0,
            track: 1.8,
            length: 4.6,
            width: 2.2,
            max_steer: 0.5,
            skid_steer: false,
            nominal_speed: 4.0,
            max_speed: 20.0,
        }
    }

    fn obs(x: f64, y: f64, yaw: f64, speed: f64) -> Observation {
        Observation {
            belief: None,
            state: VehicleState {
                position: [x, y, 0.0],
                yaw,
                speed,
                ..Default::default()
            },
        }
    }

    #[test]
    fn pid_steers_toward_a_goal_on_its_left_within_the_rate_limit() {
        let w = world(false);
        let task = Task {
            world_id: 1,
            index: 0,
            start: [0.0, 0.0],
            goal: [0.0, 50.0],
            path: vec![[0.0, 0.0], [0.0, 50.0]],
        };
        let mut p = Pid::new();
        p.reset(&PlannerContext {
            world: &w,
            task: &task,
            vehicle: &info(),
            spec: &spec(),
            sim_dt: 0.002,
            believed: false,
        })
        .unwrap();
        let a = p.act(&obs(0.0, 0.0, 0.0, 0.0)).unwrap();
        assert_eq!(
            a.steering, 0.5,
            "goal 90 degrees left: steer left, limited to 0.5 per step"
        );
        let a = p.act(&obs(0.0, 0.0, 0.0, 0.0)).unwrap();
        assert_eq!(a.steering, 1.0);
        assert!(
            a.throttle > 0.9 && a.brake == 0.0,
            "standing still: full throttle"
        );
        let a = p
            .act(&obs(0.0, 0.0, std::f64::consts::FRAC_PI_2, 8.0))
            .unwrap();
        assert!(
            a.throttle == 0.0 && a.brake > 0.0,
            "twice the nominal speed: brake"
        );
        a.validate().unwrap();
    }

    #[test]
    fn pid_local_goal_is_ten_metres_ahead_on_the_path() {
        let w = world(false).scaled(0.1);
        let task = Task {
            world_id: 1,
            index: 0,
            start: [0.0, 0.0],
            goal: [5.0, 0.0],
            path: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 3.0]],
        };
        let mut p = Pid::new();
        p.reset(&PlannerContext {
            world: &w,
            task: &task,
            vehicle: &info(),
            spec: &spec(),
            sim_dt: 0.002,
            believed: false,
        })
        .unwrap();
        // At scale 1/10 the local goal is 1 m ahead: (1, 0) from the start, straight ahead -> no steering.
        assert_eq!(p.act(&obs(0.0, 0.0, 0.0, 0.0)).unwrap().steering, 0.0);
        // From (0.5, 0) the goal is 1 m along the path: (1, 0.5), to the left.
        assert!(p.act(&obs(0.5, 0.0, 0.0, 0.0)).unwrap().steering > 0.0);
    }

    #[test]
    fn mppi_steers_around_an_obstacle_on_the_path_and_goes_straight_without_it() {
        let task = east_60m();
        let mut w = world(false);
        let mut p = mppi::Mppi::new();
        p.reset(&PlannerContext {
            world: &w,
            task: &task,
            vehicle: &info(),
            spec: &spec(),
            sim_dt: 0.002,
            believed: false,
        })
        .unwrap();
        let free = p.act(&obs(0.0, 0.0, 0.0, 4.0)).unwrap();
        assert!(free.steering.abs() < 0.15, "free path: {free:?}");
        w.obstacles.push(Obstacle {
            kind: ObstacleKind::Rock,
            x: 6.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
            half_extents: [1.5, 1.5, 1.0],
        });
        let mut p = mppi::Mppi::new();
        p.reset(&PlannerContext {
            world: &w,
            task: &task,
            vehicle: &info(),
            spec: &spec(),
            sim_dt: 0.002,
            believed: false,
        })
        .unwrap();
        let mut a = Action::default();
        for _ in 0..3 {
            a = p.act(&obs(0.0, 0.0, 0.0, 4.0)).unwrap();
        }
        assert!(
            a.steering.abs() > 0.2,
            "a rock 6 m ahead on the path: {a:?}"
        );
        a.validate().unwrap();
    }

    /// A task 60 m due east along a straight path.
    fn east_60m() -> Task {
        Task {
            world_id: 1,
            index: 0,
            start: [0.0, 0.0],
            goal: [60.0, 0.0],
            path: vec![[0.0, 0.0], [60.0, 0.0]],
        }
    }

    #[test]
    fn eh_steers_around_a_mound_ahead_and_keeps_straight_on_flat_ground() {
        let task = east_60m();
        for (mound, sign) in [(true, -1.0), (false, 0.0)] {
            let w = world(mound);
            let mut p = ElevationHeuristic::new();
            p.reset(&PlannerContext {
                world: &w,
                task: &task,
                vehicle: &info(),
                spec: &spec(),
                sim_dt: 0.002,
                believed: false,
            })
            .unwrap();
            let a = p.act(&obs(0.0, 0.0, 0.0, 4.0)).unwrap();
            let got = if a.steering.abs() < 1e-9 {
                0.0
            } else {
                a.steering.signum()
            };
            assert_eq!(got, sign, "mound {mound}: {a:?}");
        }
    }

    /// Under a perception profile EH reads the believed world its observation carries, not its context's: with
    /// the region ahead unseen (its samples `NaN`) it never picks it and turns to the first seen one (-30 degrees,
    /// as the search order has it), never reading the unseen as flat; with nothing seen at all it follows the path
    /// like PID.
    #[test]
    fn eh_judges_only_what_it_has_seen() {
        let task = east_60m();
        let truth = world(true);
        let ctx = PlannerContext {
            world: &truth,
            task: &task,
            vehicle: &info(),
            spec: &spec(),
            sim_dt: 0.002,
            believed: false,
        };
        let mut unseen_mound = truth.clone();
        for (i, h) in unseen_mound.heightmap.heights.iter_mut().enumerate() {
            let (x, y) = truth.heightmap.sample_position(i % 129, i / 129);
            if (x - 6.4).hypot(y) < 5.0 {
                *h = f32::NAN;
            }
        }
        let mut nothing_seen = truth.clone();
        nothing_seen.heightmap.heights.fill(f32::NAN);
        for (belief, seen_around) in [(unseen_mound, true), (nothing_seen, false)] {
            let mut eh = ElevationHeuristic::new();
            eh.reset(&ctx).unwrap();
            let mut pid = Pid::new();
            pid.reset(&ctx).unwrap();
            let o = Observation {
                belief: Some(std::sync::Arc::new(belief)),
                ..obs(0.0, 2.0, 0.0, 4.0)
            };
            let (a, p) = (eh.act(&o).unwrap(), pid.act(&o).unwrap());
            a.validate().unwrap();
            if seen_around {
                // Straight ahead judged flat by its seen samples: 0.8 of PID's heading error and no turn (the
                // steering is that error here, within the rate limit), where the truth's mound turns it.
                assert!(
                    (a.steering - 0.8 * p.steering).abs() < 1e-12,
                    "{a:?} vs {p:?}"
                );
            } else {
                assert_eq!(a, p);
            }
        }
    }

    /// Under a map-degrading profile the MPPI baselines plan around the obstacles the belief holds, and around none
    /// it does not (whatever the context's world held): a rock just left of the straight path.
    #[test]
    fn mppi_avoids_an_obstacle_once_the_belief_holds_it() {
        let free = world(false);
        let mut rocky = free.clone();
        rocky.obstacles.push(Obstacle {
            kind: ObstacleKind::Rock,
            x: 7.0,
            y: 1.0,
            z: 0.0,
            yaw: 0.0,
            half_extents: [1.0, 1.0, 1.0],
        });
        let task = Task {
            world_id: 1,
            index: 0,
            start: [0.0, 0.0],
            goal: [40.0, 0.0],
            path: vec![[0.0, 0.0], [40.0, 0.0]],
        };
        let (vehicle, spec) = (info(), spec());
        let ctx = |w| PlannerContext {
            world: w,
            task: &task,
            vehicle: &vehicle,
            spec: &spec,
            sim_dt: 0.002,
            believed: true,
        };
        let believing = |w: &World| Observation {
            belief: Some(std::sync::Arc::new(w.clone())),
            ..obs(0.0, 0.0, 0.0, 4.0)
        };
        for mut p in [
            Box::new(mppi::Mppi::new()) as Box<dyn Planner>,
            Box::new(mppi_release::MppiRelease::new()),
        ] {
            assert!(p.reads_belief(), "{}", p.name());
            p.reset(&ctx(&free)).unwrap();
            let clear = p.act(&believing(&free)).unwrap().steering;
            p.reset(&ctx(&free)).unwrap();
            let around = p.act(&believing(&rocky)).unwrap().steering;
            p.reset(&ctx(&rocky)).unwrap();
            let unseen = p.act(&believing(&free)).unwrap().steering;
            assert!(
                (around - clear).abs() > 0.05,
                "{}: steering {clear} on a clear path, {around} with the rock known",
                p.name()
            );
            assert_eq!(
                unseen,
                clear,
                "{}: a rock the belief lacks is not avoided",
                p.name()
            );
            if p.name() == "mppi" {
                assert!(around < clear, "MPPI steers right, away from the rock");
            }
        }
    }
}
