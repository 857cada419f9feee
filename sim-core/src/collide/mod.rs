//! Collision geometry of rigid obstacles (rocks, tree trunks) against points, spheres and oriented boxes.
//!
//! - A rock is an oriented box of `half_extents`, rotated by `yaw` about +z, standing on the ground at `z`.
//! - A tree is a vertical cylinder of radius `half_extents[0]` from `z` to `z + 2 * half_extents[2]`.
//!
//! Queries return the penetration depth and the outward unit normal of the obstacle surface, or `None`. They are
//! analytic (no allocation). A broad phase (a uniform grid built once, [`broad_phase`]) keeps the obstacles near the
//! vehicle in a fixed-capacity list refreshed by the caller (see [`ObstacleSet::refresh_near`]); the narrow phase
//! queries a sphere ([`ObstacleSet::sphere_contact`]) or an oriented box, the chassis
//! ([`ObstacleSet::box_contacts`], [`chassis`]), against the near list.
//!
//! No tunnelling: the per-step displacement at the fastest vehicle's top speed (30 m/s x 4 ms = 12 cm at full
//! scale; the step scales with sqrt(scale)) is far below the thinnest obstacle plus the thinnest colliding body
//! (a 1 m trunk plus a wheel or a chassis), so some step always overlaps, the first overlap is at most one step
//! deep and its normal opposes the motion; the penalty contacts are stiff enough to stop the vehicle within a
//! fraction of the trunk (tests: `collide_chassis` and `physics_validation`'s top-speed collision).

pub mod broad_phase;
pub mod chassis;

pub use chassis::OrientedBox;

use crate::world::{Obstacle, ObstacleKind, World};
use broad_phase::{ObstacleGrid, QueryStamps};
use nalgebra::Vector3;
use std::sync::Arc;

/// A contact with an obstacle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObstacleContact {
    pub depth: f64,
    /// Outward normal of the obstacle at the contact, unit.
    pub normal: Vector3<f64>,
    /// Contact point on the obstacle's surface.
    pub point: Vector3<f64>,
    pub obstacle: usize,
}

/// Penetration of a sphere (centre `c`, radius `r`; `r = 0` for a point) into one obstacle.
pub fn sphere_obstacle(o: &Obstacle, c: &Vector3<f64>, r: f64) -> Option<(f64, Vector3<f64>)> {
    sphere_obstacle_with(o, o.yaw.sin_cos(), c, r)
}

/// [`sphere_obstacle`] with the obstacle's `(sin, cos)` of yaw precomputed.
fn sphere_obstacle_with(
    o: &Obstacle,
    (s, co): (f64, f64),
    c: &Vector3<f64>,
    r: f64,
) -> Option<(f64, Vector3<f64>)> {
    let height = 2.0 * o.half_extents[2];
    let lz = c.z - o.z;
    match o.kind {
        ObstacleKind::Tree => {
            let (dx, dy) = (c.x - o.x, c.y - o.y);
            let d = dx.hypot(dy);
            let depth = o.half_extents[0] + r - d;
            if depth <= 0.0 || lz < -r || lz > height + r {
                return None;
            }
            let top_depth = height + r - lz;
            if top_depth < depth {
                return Some((top_depth, Vector3::z()));
            }
            let n = if d > 1e-9 {
                Vector3::new(dx / d, dy / d, 0.0)
            } else {
                Vector3::x()
            };
            Some((depth, n))
        }
        ObstacleKind::Rock => {
            let (dx, dy) = (c.x - o.x, c.y - o.y);
            // Local coordinates, box centred at the origin.
            let l = Vector3::new(co * dx + s * dy, -s * dx + co * dy, lz - o.half_extents[2]);
            let h = Vector3::new(o.half_extents[0], o.half_extents[1], o.half_extents[2]);
            let q = Vector3::new(
                l.x.clamp(-h.x, h.x),
                l.y.clamp(-h.y, h.y),
                l.z.clamp(-h.z, h.z),
            );
            let diff = l - q;
            let dist = diff.norm();
            let (depth, local_n) = if dist > 1e-12 {
                if dist >= r {
                    return None;
                }
                (r - dist, diff / dist)
            } else {
                // Centre inside the box: push out through the nearest face.
                let pen = [h.x - l.x.abs(), h.y - l.y.abs(), h.z - l.z.abs()];
                let axis = (0..3)
                    .min_by(|a, b| pen[*a].total_cmp(&pen[*b]))
                    .unwrap_or(0);
                let mut n = Vector3::zeros();
                n[axis] = if l[axis] >= 0.0 { 1.0 } else { -1.0 };
                (pen[axis] + r, n)
            };
            let n = Vector3::new(
                co * local_n.x - s * local_n.y,
                s * local_n.x + co * local_n.y,
                local_n.z,
            );
            Some((depth, n))
        }
    }
}

/// Horizontal bounding radius of an obstacle.
fn bound(o: &Obstacle) -> f64 {
    match o.kind {
        ObstacleKind::Tree => o.half_extents[0],
        ObstacleKind::Rock => o.half_extents[0]
            .hypot(o.half_extents[1])
            .hypot(o.half_extents[2]),
    }
}

/// Maximum number of obstacles kept in the near list.
pub const MAX_NEAR: usize = 32;

/// The obstacles near a point, found by [`ObstacleSet::refresh`]: ids in id order, at most [`MAX_NEAR`]. It is
/// kept by whoever moves (a vehicle's dynamic state holds its own), so one [`ObstacleSet`] serves any number of
/// them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct NearList {
    ids: [usize; MAX_NEAR],
    len: usize,
}

impl NearList {
    /// Ids of the obstacles in the list.
    pub fn ids(&self) -> &[usize] {
        &self.ids[..self.len]
    }
}

/// The obstacles of a world with a near list for the broad phase (its own, for the methods without a list
/// argument; [`NearList`]). The obstacles and their index are shared by clones (an MPPI sample's copy of a
/// simulation copies only the near list and the query scratch).
#[derive(Clone, Debug)]
pub struct ObstacleSet {
    index: Arc<Index>,
    near: NearList,
    stamps: QueryStamps,
    /// Candidate buffer of the broad phase (one slot per obstacle, allocated once).
    scratch: Vec<u32>,
}

/// The immutable half of an [`ObstacleSet`], built once per world.
#[derive(Debug)]
struct Index {
    source: Source,
    /// `(sin, cos)` of each obstacle's yaw.
    yaw_sin_cos: Vec<(f64, f64)>,
    /// Horizontal bounding radius of each obstacle.
    bounds: Vec<f64>,
    grid: ObstacleGrid,
}

/// Where the obstacles live: in the simulation's shared world (no copy), or in the set (tests, rigs).
#[derive(Debug)]
enum Source {
    World(Arc<World>),
    Own(Vec<Obstacle>),
}

impl Source {
    fn obstacles(&self) -> &[Obstacle] {
        match self {
            Source::World(w) => &w.obstacles,
            Source::Own(o) => o,
        }
    }
}

impl ObstacleSet {
    /// The obstacles of a shared world, read from it (not copied).
    pub fn of_world(world: Arc<World>) -> ObstacleSet {
        ObstacleSet::build(Source::World(world))
    }

    /// A set of these obstacles (copied into the set).
    pub fn new(obstacles: &[Obstacle]) -> ObstacleSet {
        ObstacleSet::build(Source::Own(obstacles.to_vec()))
    }

    fn build(source: Source) -> ObstacleSet {
        let (yaw_sin_cos, bounds, grid, n) = {
            let obstacles = source.obstacles();
            let bounds: Vec<f64> = obstacles.iter().map(bound).collect();
            let centres: Vec<(f64, f64)> = obstacles.iter().map(|o| (o.x, o.y)).collect();
            let grid = ObstacleGrid::new(&centres, &bounds);
            (
                obstacles.iter().map(|o| o.yaw.sin_cos()).collect(),
                bounds,
                grid,
                obstacles.len(),
            )
        };
        ObstacleSet {
            index: Arc::new(Index {
                source,
                yaw_sin_cos,
                bounds,
                grid,
            }),
            near: NearList::default(),
            stamps: QueryStamps::new(n),
            scratch: vec![0; n],
        }
    }

    pub fn obstacles(&self) -> &[Obstacle] {
        self.index.source.obstacles()
    }

    /// Keeps the obstacles whose bounding circle comes within `radius` of `(x, y)`: at most [`MAX_NEAR`], the lowest
    /// ids first (the list is in id order, so results do not depend on the grid's layout).
    pub fn refresh_near(&mut self, x: f64, y: f64, radius: f64) {
        let mut near = self.near;
        self.refresh(&mut near, x, y, radius);
        self.near = near;
    }

    /// [`ObstacleSet::refresh_near`] into a list kept by the caller (`&mut self`: the broad phase's scratch).
    pub fn refresh(&mut self, near: &mut NearList, x: f64, y: f64, radius: f64) {
        near.len = 0;
        let n = self
            .index
            .grid
            .candidates(&mut self.stamps, x, y, radius, &mut self.scratch);
        let found = &mut self.scratch[..n];
        found.sort_unstable();
        let obstacles = self.index.source.obstacles();
        for &i in found.iter() {
            let o = &obstacles[i as usize];
            if (o.x - x).hypot(o.y - y) <= radius + self.index.bounds[i as usize]
                && near.len < MAX_NEAR
            {
                near.ids[near.len] = i as usize;
                near.len += 1;
            }
        }
    }

    /// Ids of the obstacles in the near list.
    pub fn near(&self) -> &[usize] {
        self.near.ids()
    }

    /// Whether any near obstacle comes within `radius` of `(x, y)` (a quick test before many point queries).
    pub fn any_within(&self, x: f64, y: f64, radius: f64) -> bool {
        self.any_within_in(&self.near, x, y, radius)
    }

    /// [`ObstacleSet::any_within`] among the obstacles of `near`.
    pub fn any_within_in(&self, near: &NearList, x: f64, y: f64, radius: f64) -> bool {
        let obstacles = self.obstacles();
        near.ids().iter().any(|&i| {
            let o = &obstacles[i];
            (o.x - x).hypot(o.y - y) <= radius + self.index.bounds[i]
        })
    }

    /// Contacts of an oriented box (the chassis) with the near obstacles, one per touching obstacle in id order,
    /// written into `out`; returns how many (at most `out.len()`, further contacts are dropped).
    pub fn box_contacts(&self, b: &OrientedBox, out: &mut [ObstacleContact]) -> usize {
        let (mut n, obstacles) = (0, self.obstacles());
        for &i in self.near.ids() {
            if n == out.len() {
                break;
            }
            if let Some(mut c) = chassis::box_obstacle(&obstacles[i], self.index.yaw_sin_cos[i], b)
            {
                c.obstacle = i;
                out[n] = c;
                n += 1;
            }
        }
        n
    }

    /// Deepest contact of a sphere with the near obstacles.
    pub fn sphere_contact(&self, c: &Vector3<f64>, r: f64) -> Option<ObstacleContact> {
        self.sphere_contact_in(&self.near, c, r)
    }

    /// [`ObstacleSet::sphere_contact`] among the obstacles of `near`.
    pub fn sphere_contact_in(
        &self,
        near: &NearList,
        c: &Vector3<f64>,
        r: f64,
    ) -> Option<ObstacleContact> {
        let (mut best, obstacles) = (None::<ObstacleContact>, self.obstacles());
        for &i in near.ids() {
            if let Some((depth, normal)) =
                sphere_obstacle_with(&obstacles[i], self.index.yaw_sin_cos[i], c, r)
            {
                if best.is_none_or(|b| depth > b.depth) {
                    best = Some(ObstacleContact {
                        depth,
                        normal,
                        point: c - normal * (r - depth),
                        obstacle: i,
                    });
                }
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rock(yaw: f64) -> Obstacle {
        Obstacle {
            kind: ObstacleKind::Rock,
            x: 0.0,
            y: 0.0,
            z: 0.0,
            yaw,
            half_extents: [2.0, 1.0, 1.5],
        }
    }

    #[test]
    fn point_inside_a_rock_is_pushed_out_through_the_nearest_face() {
        let (d, n) = sphere_obstacle(&rock(0.0), &Vector3::new(1.8, 0.0, 1.5), 0.0).unwrap();
        assert!((d - 0.2).abs() < 1e-12 && (n - Vector3::x()).norm() < 1e-12);
        // Rotated by 90 degrees the long axis points along y.
        let (d, n) = sphere_obstacle(
            &rock(std::f64::consts::FRAC_PI_2),
            &Vector3::new(0.0, 1.8, 1.5),
            0.0,
        )
        .unwrap();
        assert!(
            (d - 0.2).abs() < 1e-9 && (n - Vector3::y()).norm() < 1e-9,
            "{d} {n}"
        );
        assert!(sphere_obstacle(&rock(0.0), &Vector3::new(2.5, 0.0, 1.0), 0.4).is_none());
        let (d, _) = sphere_obstacle(&rock(0.0), &Vector3::new(2.3, 0.0, 1.0), 0.4).unwrap();
        assert!((d - 0.1).abs() < 1e-12);
    }

    #[test]
    fn tree_contacts_are_radial_and_limited_in_height() {
        let tree = Obstacle {
            kind: ObstacleKind::Tree,
            x: 1.0,
            y: 1.0,
            z: 2.0,
            yaw: 0.0,
            half_extents: [0.5, 0.5, 2.5],
        };
        let (d, n) = sphere_obstacle(&tree, &Vector3::new(1.0, 1.6, 3.0), 0.2).unwrap();
        assert!((d - 0.1).abs() < 1e-12 && (n - Vector3::y()).norm() < 1e-12);
        assert!(sphere_obstacle(&tree, &Vector3::new(1.0, 1.6, 8.0), 0.2).is_none());
        assert!(sphere_obstacle(&tree, &Vector3::new(1.0, 1.6, 1.0), 0.2).is_none());
    }

    #[test]
    fn near_list_keeps_only_close_obstacles() {
        let far = Obstacle {
            x: 50.0,
            ..rock(0.0)
        };
        let mut set = ObstacleSet::new(&[rock(0.0), far]);
        set.refresh_near(0.0, 0.0, 5.0);
        assert!(set
            .sphere_contact(&Vector3::new(0.0, 0.0, 1.0), 0.1)
            .is_some());
        assert!(
            set.sphere_contact(&Vector3::new(50.0, 0.0, 1.0), 0.1)
                .is_none(),
            "far rock is not in the near list"
        );
    }
}
