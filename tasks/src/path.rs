//! Global paths: A* for a holonomic point mass on the 8-connected sample grid, with true diagonal costs (sqrt 2)
//! and the octile-distance heuristic (admissible and consistent, so paths are optimal on the grid). A sample is
//! blocked when it lies inside an obstacle footprint inflated by the vehicle's footprint radius.

use crate::obstacles::occupies;
use sim_core::world::World;
use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// Half-diagonal footprint radius of the full-scale HMMWV used for the stored paths, m
/// (overall length about 4.6 m and width about 2.2 m: sqrt(2.3^2 + 1.1^2) = 2.55 m, rounded up).
pub const DEFAULT_INFLATION: f64 = 2.6;

/// Occupancy of the sample grid (`true` = blocked) for obstacles inflated by `inflation` m.
pub fn occupancy(world: &World, inflation: f64) -> Vec<bool> {
    let h = &world.heightmap;
    let mut grid = vec![false; h.nx * h.ny];
    for o in &world.obstacles {
        let r = crate::obstacles::footprint_radius(o) + inflation;
        let (fx, fy) = h.grid_coords(o.x, o.y);
        let span = (r / h.cell).ceil() as i64 + 1;
        for iy in (fy.round() as i64 - span)..=(fy.round() as i64 + span) {
            for ix in (fx.round() as i64 - span)..=(fx.round() as i64 + span) {
                if ix < 0 || iy < 0 || ix >= h.nx as i64 || iy >= h.ny as i64 {
                    continue;
                }
                let (x, y) = h.sample_position(ix as usize, iy as usize);
                if occupies(o, x, y, inflation) {
                    grid[iy as usize * h.nx + ix as usize] = true;
                }
            }
        }
    }
    grid
}

#[derive(PartialEq)]
struct Node {
    f: f64,
    g: f64,
    idx: usize,
}
impl Eq for Node {}
impl Ord for Node {
    fn cmp(&self, other: &Self) -> Ordering {
        // Min-heap on f, ties broken by larger g then index, for a deterministic order.
        other
            .f
            .total_cmp(&self.f)
            .then(self.g.total_cmp(&other.g))
            .then(other.idx.cmp(&self.idx))
    }
}
impl PartialOrd for Node {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

/// Plans a path from `start` to `goal` (world coordinates) avoiding obstacles inflated by `inflation` m.
/// Returns the waypoints (start, grid samples, goal), or `None` when the goal is unreachable.
pub fn plan_path(
    world: &World,
    start: [f64; 2],
    goal: [f64; 2],
    inflation: f64,
) -> Option<Vec<[f64; 2]>> {
    let blocked = occupancy(world, inflation);
    plan_on_grid(world, &blocked, start, goal)
}

/// A* on a precomputed occupancy grid (see [`occupancy`]).
pub fn plan_on_grid(
    world: &World,
    blocked: &[bool],
    start: [f64; 2],
    goal: [f64; 2],
) -> Option<Vec<[f64; 2]>> {
    let h = &world.heightmap;
    let (nx, ny) = (h.nx, h.ny);
    let to_idx = |p: [f64; 2]| -> Option<usize> {
        let (fx, fy) = h.grid_coords(p[0], p[1]);
        let (ix, iy) = (fx.round(), fy.round());
        (ix >= 0.0 && iy >= 0.0 && (ix as usize) < nx && (iy as usize) < ny)
            .then(|| iy as usize * nx + ix as usize)
    };
    let (s, g) = (to_idx(start)?, to_idx(goal)?);
    if blocked[s] || blocked[g] {
        return None;
    }
    let octile = |a: usize| {
        let dx = (a % nx).abs_diff(g % nx) as f64;
        let dy = (a / nx).abs_diff(g / nx) as f64;
        (dx.max(dy) - dx.min(dy)) + std::f64::consts::SQRT_2 * dx.min(dy)
    };
    let mut cost = vec![f64::INFINITY; nx * ny];
    let mut parent = vec![usize::MAX; nx * ny];
    let mut open = BinaryHeap::new();
    cost[s] = 0.0;
    open.push(Node {
        f: octile(s),
        g: 0.0,
        idx: s,
    });
    while let Some(Node { g: gc, idx, .. }) = open.pop() {
        if idx == g {
            break;
        }
        if gc > cost[idx] {
            continue;
        }
        for (q, step) in h.grid_neighbours(idx) {
            if blocked[q] {
                continue;
            }
            let ng = gc + step;
            if ng < cost[q] {
                cost[q] = ng;
                parent[q] = idx;
                open.push(Node {
                    f: ng + octile(q),
                    g: ng,
                    idx: q,
                });
            }
        }
    }
    if !cost[g].is_finite() {
        return None;
    }
    let mut cells = vec![g];
    while *cells.last().expect("non-empty") != s {
        cells.push(parent[*cells.last().expect("non-empty")]);
    }
    cells.reverse();
    // Keep only the cells where the grid direction changes: the polyline is the same, the file much smaller.
    let dir = |a: usize, b: usize| {
        (
            (b % nx) as i64 - (a % nx) as i64,
            (b / nx) as i64 - (a / nx) as i64,
        )
    };
    let mut path = Vec::with_capacity(cells.len() + 2);
    path.push(start);
    for k in 1..cells.len().saturating_sub(1) {
        if dir(cells[k - 1], cells[k]) != dir(cells[k], cells[k + 1]) {
            let (x, y) = h.sample_position(cells[k] % nx, cells[k] / nx);
            path.push([x, y]);
        }
    }
    path.push(goal);
    Some(path)
}

/// Length of a polyline, m.
pub fn path_length(path: &[[f64; 2]]) -> f64 {
    path.windows(2)
        .map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim_core::world::*;

    fn world(obstacles: Vec<Obstacle>) -> World {
        let flat = Heightmap::from_fn(1.0, |_, _| 0.0);
        World {
            obstacles,
            ..World::uniform(flat, Semantic::Dirt, Surface::Rigid { friction: 0.6 })
        }
    }

    #[test]
    fn free_straight_and_diagonal_paths_have_exact_grid_costs() {
        let w = world(vec![]);
        let p = plan_path(&w, [-60.0, 0.0], [60.0, 0.0], 2.6).unwrap();
        assert!((path_length(&p) - 120.0).abs() < 1e-9);
        let p = plan_path(&w, [-40.0, -40.0], [40.0, 40.0], 2.6).unwrap();
        assert!((path_length(&p) - 80.0 * std::f64::consts::SQRT_2).abs() < 1e-9);
    }

    #[test]
    fn path_goes_around_an_inflated_tree_and_keeps_clearance() {
        let tree = Obstacle {
            kind: ObstacleKind::Tree,
            x: 0.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
            half_extents: [0.5, 0.5, 2.5],
        };
        let w = world(vec![tree]);
        let p = plan_path(&w, [-60.0, 0.0], [60.0, 0.0], 2.6).unwrap();
        assert!(path_length(&p) > 120.0);
        for q in &p {
            assert!(
                q[0].hypot(q[1]) > 0.5 + 2.6 - 1e-9,
                "waypoint {q:?} inside the inflated tree"
            );
        }
    }

    #[test]
    fn an_enclosed_goal_is_unreachable() {
        let wall: Vec<Obstacle> = (0..40)
            .map(|k| {
                let a = k as f64 / 40.0 * std::f64::consts::TAU;
                Obstacle {
                    kind: ObstacleKind::Tree,
                    x: 10.0 * a.cos(),
                    y: 10.0 * a.sin(),
                    z: 0.0,
                    yaw: 0.0,
                    half_extents: [0.5, 0.5, 2.5],
                }
            })
            .collect();
        assert!(plan_path(&world(wall), [-60.0, 0.0], [0.0, 0.0], 1.0).is_none());
    }
}
