//! What the MPPI-6 planners share, whatever model rolls their samples out (our simulator in `baselines::mppi6`, a
//! learned model in the `learned` crate), so that neither depends on the other: the plan's knots and their
//! interpolation, the speed controller the rollouts and the execution both run, the cost-to-go field, the cost of
//! one rollout step, and the inflated obstacle grid (which the bicycle MPPI and the release's MPPI use too).

use sim_core::planner::{Action, PlannerContext};
use sim_core::world::World;

/// Control knots over the horizon (the first at the decision time, the last at the horizon).
pub const KNOTS: usize = 4;
/// The paper's rollover threshold, deg.
pub const ROLLOVER_DEG: f64 = 30.0;

/// One step of the speed controller (the baselines' PI, to `target` m/s, called at `rate_hz`): the action and the
/// new integral.
pub fn speed_control(
    speed: f64,
    target: f64,
    integral: f64,
    nominal: f64,
    steering: f64,
    rate_hz: f64,
) -> (Action, f64) {
    let err = target - speed;
    let integral = (integral + err / rate_hz).clamp(-2.0, 2.0);
    let u = (err + 0.3 * integral) / nominal.max(1e-6);
    // Forward: drive with u > 0, brake with u < 0; reverse (negative target): drive backwards with u < 0.
    let (throttle, brake) = if target >= 0.0 {
        (u.clamp(0.0, 1.0), (-u).clamp(0.0, 1.0) * 0.5)
    } else {
        (u.clamp(-1.0, 0.0), u.clamp(0.0, 1.0) * 0.5)
    };
    (
        Action {
            steering: steering.clamp(-1.0, 1.0),
            throttle,
            brake,
        },
        integral,
    )
}

/// The plan at time `t` after its start (knots spaced `spacing` apart; held after the last).
pub fn interp(knots: &[[f64; 2]; KNOTS], t: f64, spacing: f64) -> [f64; 2] {
    let f = (t / spacing).max(0.0);
    let i = (f as usize).min(KNOTS - 1);
    if i + 1 >= KNOTS {
        return knots[KNOTS - 1];
    }
    let u = f - i as f64;
    [
        knots[i][0] + u * (knots[i + 1][0] - knots[i][0]),
        knots[i][1] + u * (knots[i + 1][1] - knots[i][1]),
    ]
}

/// Speed factors (times the nominal speed); negative drives backwards.
pub const SPEED_MIN: f64 = -0.5;
pub const SPEED_MAX: f64 = 1.0;

/// Cost-to-go: the shortest distance to the goal on the heightmap grid around obstacles (inflated by half the
/// vehicle's width; crossing them costs 20 times the distance), m.
#[derive(Clone, Debug, Default)]
pub struct CostToGo {
    /// `togo[iy * nx + ix]`, m.
    togo: Vec<f64>,
    grid: (usize, usize, f64),
}

impl CostToGo {
    /// The field to `goal` on `ctx`'s world (Dijkstra from the goal's cell, 8-neighbour).
    pub fn new(ctx: &PlannerContext<'_>, goal: [f64; 2]) -> CostToGo {
        use std::cmp::Reverse;
        use std::collections::BinaryHeap;
        let h = &ctx.world.heightmap;
        let (nx, ny, cell) = (h.nx, h.ny, h.cell);
        let blocked = inflated_obstacles(ctx.world, 0.5 * ctx.vehicle.width);
        let (gx, gy) = h.grid_coords(goal[0], goal[1]);
        let g = (gy.round().clamp(0.0, (ny - 1) as f64) as usize) * nx
            + gx.round().clamp(0.0, (nx - 1) as f64) as usize;
        let mut togo = vec![f64::INFINITY; nx * ny];
        togo[g] = 0.0;
        // Costs are compared as integers (micrometres) so the order is total and deterministic.
        let mut heap = BinaryHeap::new();
        heap.push(Reverse((0u64, g)));
        while let Some(Reverse((d, i))) = heap.pop() {
            let d = d as f64 * 1e-6;
            if d > togo[i] {
                continue;
            }
            for (q, cells) in h.grid_neighbours(i) {
                let step = cell * cells;
                let nd = d + step * if blocked[q] { 20.0 } else { 1.0 };
                if nd < togo[q] {
                    togo[q] = nd;
                    heap.push(Reverse(((nd * 1e6) as u64, q)));
                }
            }
        }
        CostToGo {
            togo,
            grid: (nx, ny, cell),
        }
    }

    /// Cost-to-go at a point (bilinear between grid samples), m.
    pub fn at(&self, x: f64, y: f64) -> f64 {
        let (nx, ny, cell) = self.grid;
        let fx = (x / cell + (nx - 1) as f64 * 0.5).clamp(0.0, (nx - 1) as f64 - 1e-9);
        let fy = (y / cell + (ny - 1) as f64 * 0.5).clamp(0.0, (ny - 1) as f64 - 1e-9);
        let (ix, iy) = (fx as usize, fy as usize);
        let (tx, ty) = (fx - ix as f64, fy - iy as f64);
        let v = |i: usize, j: usize| self.togo[j * nx + i];
        (1.0 - ty) * ((1.0 - tx) * v(ix, iy) + tx * v(ix + 1, iy))
            + ty * ((1.0 - tx) * v(ix, iy + 1) + tx * v(ix + 1, iy + 1))
    }
}

/// The cost of one rollout step, before dividing by the steps of the horizon: progress toward the goal around
/// obstacles in horizons' worth of nominal driving (`progress`, negative ahead), the distance to the local goal over
/// its distance at the decision (`d`), and the attitude (deg): `10 progress + 2 d^2 + 2 (roll / 30)^2 +
/// (pitch / 30)^2`, plus 20 when `|roll| > 25` deg.
pub fn step_cost(progress: f64, d: f64, roll_deg: f64, pitch_deg: f64) -> f64 {
    let roll_deg = roll_deg.abs();
    let pitch = pitch_deg / ROLLOVER_DEG;
    let r = roll_deg / ROLLOVER_DEG;
    let mut c = 10.0 * progress + 2.0 * d * d + 2.0 * r * r + pitch * pitch;
    if roll_deg > 25.0 {
        c += 20.0;
    }
    c
}

/// The new plan: the samples' mean weighted by `exp(-(cost - min) / lambda)`, lambda a tenth of the spread between
/// the best and the median cost (at least 1e-6).
///
/// # Panics
/// If there are no samples.
pub fn softmin_plan(costs: &[f64], samples: &[[[f64; 2]; KNOTS]]) -> [[f64; 2]; KNOTS] {
    let lo = costs.iter().copied().fold(f64::INFINITY, f64::min);
    let mut sorted = costs.to_vec();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    let lambda = (0.1 * (median - lo)).max(1e-6);
    let mut sum = 0.0;
    let mut mean = [[0.0; 2]; KNOTS];
    for (c, sample) in costs.iter().zip(samples) {
        let w = (-(c - lo) / lambda).exp();
        sum += w;
        for (m, x) in mean.iter_mut().zip(sample) {
            m[0] += w * x[0];
            m[1] += w * x[1];
        }
    }
    mean.map(|m| [m[0] / sum, m[1] / sum])
}

/// The map grid's obstacle cells (`sim_core::observe::occupancy_grid`) inflated by a disc of `radius` m: the cells
/// a point vehicle of that half width must not enter. Row-major, `nx * ny`.
pub fn inflated_obstacles(world: &World, radius: f64) -> Vec<bool> {
    let h = &world.heightmap;
    let (nx, ny) = (h.nx, h.ny);
    let occ = sim_core::observe::occupancy_grid(world);
    let r = (radius / h.cell).ceil() as i64;
    let mut blocked = vec![false; nx * ny];
    for iy in 0..ny as i64 {
        for ix in 0..nx as i64 {
            if occ[iy as usize * nx + ix as usize] == 0 {
                continue;
            }
            for dy in -r..=r {
                for dx in -r..=r {
                    let (qx, qy) = (ix + dx, iy + dy);
                    if qx >= 0
                        && qy >= 0
                        && qx < nx as i64
                        && qy < ny as i64
                        && dx * dx + dy * dy <= r * r
                    {
                        blocked[qy as usize * nx + qx as usize] = true;
                    }
                }
            }
        }
    }
    blocked
}
