//! A simple built-in path follower (pure pursuit with a P speed controller), used by `vb sim run` and the tests.
//! The benchmark's baselines live in the `baselines` crate.

use crate::planner::{Action, Observation, Planner, PlannerContext, PlannerError};

/// Projects `pos` on the polyline `path` (searching segments from `from` on, so progress is monotone) and returns
/// the point `ahead` metres further along the path (the last point if the path ends sooner) and the index of the
/// segment the projection lies on.
pub fn point_ahead(path: &[[f64; 2]], pos: [f64; 2], from: usize, ahead: f64) -> ([f64; 2], usize) {
    if path.len() < 2 {
        return (path.first().copied().unwrap_or(pos), 0);
    }
    let mut best = (f64::INFINITY, from.min(path.len() - 2), 0.0);
    for i in from.min(path.len() - 2)..path.len() - 1 {
        let (a, b) = (path[i], path[i + 1]);
        let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 {
            (((pos[0] - a[0]) * dx + (pos[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let d = (a[0] + t * dx - pos[0]).hypot(a[1] + t * dy - pos[1]);
        if d < best.0 {
            best = (d, i, t);
        }
    }
    let (_, seg, t) = best;
    let mut remaining = ahead;
    let mut a = [
        path[seg][0] + t * (path[seg + 1][0] - path[seg][0]),
        path[seg][1] + t * (path[seg + 1][1] - path[seg][1]),
    ];
    for &b in &path[seg + 1..] {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        if len >= remaining && len > 0.0 {
            let u = remaining / len;
            return ([a[0] + u * (b[0] - a[0]), a[1] + u * (b[1] - a[1])], seg);
        }
        remaining -= len;
        a = b;
    }
    (*path.last().expect("non-empty"), seg)
}

/// Pure pursuit on the task's global path.
#[derive(Clone, Debug)]
pub struct PurePursuit {
    path: Vec<[f64; 2]>,
    lookahead: f64,
    speed: f64,
    wheelbase: f64,
    max_steer: f64,
    skid: bool,
    progress: usize,
}

impl PurePursuit {
    pub fn new() -> Self {
        PurePursuit {
            path: Vec::new(),
            lookahead: 6.0,
            speed: 4.0,
            wheelbase: 3.0,
            max_steer: 0.5,
            skid: false,
            progress: 0,
        }
    }
}

impl Default for PurePursuit {
    fn default() -> Self {
        Self::new()
    }
}

impl Planner for PurePursuit {
    fn name(&self) -> &str {
        "pure_pursuit"
    }
    fn control_rate_hz(&self) -> f64 {
        20.0
    }
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.path = ctx.task.path.clone();
        let s = ctx.vehicle.scale;
        self.lookahead = 6.0 * s;
        self.speed = ctx.vehicle.nominal_speed;
        self.wheelbase = ctx.vehicle.wheelbase;
        self.max_steer = ctx.vehicle.max_steer;
        self.skid = ctx.vehicle.skid_steer;
        self.progress = 0;
        Ok(())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let s = &obs.state;
        let (x, y) = (s.position[0], s.position[1]);
        let (target, progress) = point_ahead(&self.path, [x, y], self.progress, self.lookahead);
        self.progress = progress;
        let alpha = (target[1] - y).atan2(target[0] - x) - s.yaw;
        let alpha = alpha.sin().atan2(alpha.cos());
        let steering = if self.skid {
            (2.0 * alpha).clamp(-1.0, 1.0)
        } else {
            let delta = (2.0 * self.wheelbase * alpha.sin() / self.lookahead.max(1e-6)).atan();
            (delta / self.max_steer.max(1e-6)).clamp(-1.0, 1.0)
        };
        let err = self.speed - s.speed;
        let throttle = (err / self.speed.max(1e-6)).clamp(0.0, 1.0);
        let brake = if err < -0.3 * self.speed { 0.3 } else { 0.0 };
        Ok(Action {
            steering,
            throttle,
            brake,
        })
    }
    fn reads_world_maps(&self) -> bool {
        false
    }
}
