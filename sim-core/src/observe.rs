//! Ground-truth observations for planners: heading-aligned crops of the elevation, semantics and obstacle maps
//! around the vehicle, of a chosen size and resolution, and the full obstacle occupancy grid.
//!
//! A crop is `size x size` cells of `resolution` metres, centred on the vehicle and rotated with its heading:
//! row `r` (0 = front) lies `((size - 1) / 2 - r) * resolution` ahead of the vehicle, column `c` (0 = left)
//! `((size - 1) / 2 - c) * resolution` to its left. Cells off the map repeat the map edge (elevation), take class
//! 255 (semantics) and count as occupied (obstacles). Crops are written into caller-provided buffers, so a planner
//! can call them at every step without allocating.

use crate::collide::sphere_obstacle;
use crate::planner::VehicleState;
use crate::world::{Surface, World};
use nalgebra::Vector3;

/// Shape of a crop: `size x size` cells of `resolution` m, aligned with the heading (datasets record it as is).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CropSpec {
    pub size: usize,
    /// Metres per cell.
    pub resolution: f64,
}

/// World position of crop cell `(row, col)`.
pub fn cell_position(state: &VehicleState, spec: &CropSpec, row: usize, col: usize) -> (f64, f64) {
    let half = (spec.size as f64 - 1.0) / 2.0;
    let ahead = (half - row as f64) * spec.resolution;
    let left = (half - col as f64) * spec.resolution;
    let (s, c) = state.yaw.sin_cos();
    (
        state.position[0] + c * ahead - s * left,
        state.position[1] + s * ahead + c * left,
    )
}

fn fill<T: Copy>(
    state: &VehicleState,
    spec: &CropSpec,
    out: &mut [T],
    mut f: impl FnMut(f64, f64) -> T,
) {
    let n = spec.size;
    for (k, v) in out.iter_mut().enumerate().take(n * n) {
        let (x, y) = cell_position(state, spec, k / n, k % n);
        *v = f(x, y);
    }
}

/// Heading-aligned elevation crop (metres, bilinear), `out.len() >= size * size`.
pub fn elevation_crop(world: &World, state: &VehicleState, spec: &CropSpec, out: &mut [f32]) {
    fill(state, spec, out, |x, y| {
        world.heightmap.height_bilinear(x, y) as f32
    });
}

/// Heading-aligned semantic crop (release label ids; 255 off the map).
pub fn semantics_crop(world: &World, state: &VehicleState, spec: &CropSpec, out: &mut [u8]) {
    fill(state, spec, out, |x, y| {
        if world.heightmap.contains(x, y) {
            world.patch_at(x, y).semantic.id()
        } else {
            255
        }
    });
}

/// Whether a world point lies inside an obstacle's footprint.
pub fn occupied(world: &World, x: f64, y: f64) -> bool {
    world.obstacles.iter().any(|o| occupied_by(o, x, y))
}

/// Whether a world point lies inside the footprint of obstacle `o`.
pub fn occupied_by(o: &crate::world::Obstacle, x: f64, y: f64) -> bool {
    let top = Vector3::new(x, y, o.z + o.half_extents[2]);
    sphere_obstacle(o, &top, 0.0).is_some()
}

/// Heading-aligned obstacle crop (1 = occupied or off the map). Each obstacle is tested only on the cells its
/// bounding circle covers, so the cost grows with the obstacles near the vehicle, not with all of them; the result
/// is [`occupied`]'s at every cell.
pub fn obstacle_crop(world: &World, state: &VehicleState, spec: &CropSpec, out: &mut [u8]) {
    fill(state, spec, out, |x, y| {
        u8::from(!world.heightmap.contains(x, y))
    });
    let n = spec.size;
    if n == 0 {
        return;
    }
    let half = (n as f64 - 1.0) / 2.0;
    let (s, c) = state.yaw.sin_cos();
    let last = (n - 1) as f64;
    for o in &world.obstacles {
        // Cell (row, col) lies (half - row) * res ahead and (half - col) * res to the left of the vehicle.
        let (dx, dy) = (o.x - state.position[0], o.y - state.position[1]);
        let (ahead, left) = (c * dx + s * dy, -s * dx + c * dy);
        let reach = o.half_extents[0].hypot(o.half_extents[1]) / spec.resolution + 1.0;
        let (row, col) = (
            half - ahead / spec.resolution,
            half - left / spec.resolution,
        );
        if row + reach < 0.0 || row - reach > last || col + reach < 0.0 || col - reach > last {
            continue;
        }
        let rows =
            (row - reach).max(0.0).floor() as usize..=(row + reach).min(last).ceil() as usize;
        let cols =
            (col - reach).max(0.0).floor() as usize..=(col + reach).min(last).ceil() as usize;
        for r in rows {
            for k in cols.clone() {
                let v = &mut out[r * n + k];
                if *v == 0 {
                    let (x, y) = cell_position(state, spec, r, k);
                    let top = Vector3::new(x, y, o.z + o.half_extents[2]);
                    *v = u8::from(sphere_obstacle(o, &top, 0.0).is_some());
                }
            }
        }
    }
}

/// Names of [`state_vector`]'s entries, in order (world frame, SI units, angles in rad): the Python SDK's
/// `state` and the datasets' `observation.state`.
pub const STATE_FIELDS: [&str; 15] = [
    "x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "wx", "wy", "wz", "speed", "steering",
    "time",
];

/// Names of [`goal_vector`]'s entries: the goal in the vehicle's heading frame (m ahead, m to the left) and its
/// horizontal distance (m).
pub const GOAL_FIELDS: [&str; 3] = ["ahead", "left", "distance"];

/// The vehicle's state as one vector ([`STATE_FIELDS`]): what the Python SDK's environments observe and the
/// datasets record.
pub fn state_vector(s: &VehicleState) -> [f64; 15] {
    let [x, y, z] = s.position;
    let [vx, vy, vz] = s.velocity;
    let [wx, wy, wz] = s.angular_velocity;
    [
        x, y, z, s.roll, s.pitch, s.yaw, vx, vy, vz, wx, wy, wz, s.speed, s.steering, s.time,
    ]
}

/// The state a [`state_vector`] was made from (its inverse): how a recorded `observation.state` becomes a
/// [`VehicleState`] again.
pub fn state_from_vector(v: &[f64; 15]) -> VehicleState {
    VehicleState {
        time: v[14],
        position: [v[0], v[1], v[2]],
        roll: v[3],
        pitch: v[4],
        yaw: v[5],
        velocity: [v[6], v[7], v[8]],
        angular_velocity: [v[9], v[10], v[11]],
        speed: v[12],
        steering: v[13],
    }
}

/// The goal `(x, y)` in the vehicle's heading frame ([`GOAL_FIELDS`]): m ahead, m to the left (rotated by the yaw
/// only) and the horizontal distance.
pub fn goal_vector(s: &VehicleState, goal: [f64; 2]) -> [f64; 3] {
    let (dx, dy) = (goal[0] - s.position[0], goal[1] - s.position[1]);
    let (sn, c) = s.yaw.sin_cos();
    [c * dx + sn * dy, -sn * dx + c * dy, dx.hypot(dy)]
}

/// [`elevation_crop`] relative to the height of the vehicle's reference point (crop minus its `z`, in `f32`): the
/// elevation the Python SDK observes and the datasets record.
pub fn relative_elevation_crop(
    world: &World,
    state: &VehicleState,
    spec: &CropSpec,
    out: &mut [f32],
) {
    elevation_crop(world, state, spec, out);
    let z = state.position[2] as f32;
    out.iter_mut()
        .take(spec.size * spec.size)
        .for_each(|h| *h -= z);
}

/// Semantic label id of every heightmap sample, `grid[iy * nx + ix]`.
pub fn semantics_grid(world: &World) -> Vec<u8> {
    sample_grid(world, |x, y| world.patch_at(x, y).semantic.id())
}

/// Coulomb friction of every heightmap sample on rigid ground (0 where the ground is deformable),
/// `grid[iy * nx + ix]`.
pub fn friction_grid(world: &World) -> Vec<f32> {
    sample_grid(world, |x, y| match world.patch_at(x, y).surface {
        Surface::Rigid { friction } => friction as f32,
        Surface::Deformable { .. } => 0.0,
    })
}

fn sample_grid<T>(world: &World, mut f: impl FnMut(f64, f64) -> T) -> Vec<T> {
    let h = &world.heightmap;
    let mut grid = Vec::with_capacity(h.nx * h.ny);
    for iy in 0..h.ny {
        for ix in 0..h.nx {
            let (x, y) = h.sample_position(ix, iy);
            grid.push(f(x, y));
        }
    }
    grid
}

/// Obstacle occupancy of every heightmap sample, `grid[iy * nx + ix]`.
pub fn occupancy_grid(world: &World) -> Vec<u8> {
    sample_grid(world, |x, y| u8::from(occupied(world, x, y)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::*;

    fn world() -> World {
        // Height = x, so "ahead" is easy to read off the crop; the patch containing (10, 0) is grass; a tree at (0, 5).
        let mut w = World::uniform(
            Heightmap::from_fn(1.0, |x, _| x),
            Semantic::Dirt,
            Surface::Rigid { friction: 0.6 },
        );
        let k = w.patch_index_at(10.0, 0.0);
        w.patches[k] = Patch {
            semantic: Semantic::Grass,
            surface: Surface::Rigid { friction: 0.4 },
        };
        w.obstacles.push(Obstacle {
            kind: ObstacleKind::Tree,
            x: 0.0,
            y: 5.0,
            z: 0.0,
            yaw: 0.0,
            half_extents: [0.5, 0.5, 2.5],
        });
        w
    }

    #[test]
    fn crops_are_aligned_with_the_heading() {
        let w = world();
        let spec = CropSpec {
            size: 5,
            resolution: 1.0,
        };
        let state = VehicleState {
            yaw: std::f64::consts::FRAC_PI_2,
            ..Default::default()
        };
        // Facing +y (north): the crop's left column lies to the west (x = -2), its right column to the east.
        let mut e = vec![0f32; 25];
        elevation_crop(&w, &state, &spec, &mut e);
        assert!(
            (e[0] - (-2.0)).abs() < 1e-5 && (e[4] - 2.0).abs() < 1e-5,
            "{e:?}"
        );
        // The tree at (0, 5) is 5 m ahead: in a crop of 11 cells, row 0 is 5 m ahead, centre column.
        let spec = CropSpec {
            size: 11,
            resolution: 1.0,
        };
        let mut o = vec![0u8; 121];
        obstacle_crop(&w, &state, &spec, &mut o);
        assert_eq!(o[5], 1);
        assert_eq!(o[60], 0);
    }

    #[test]
    fn obstacle_crop_equals_the_occupancy_of_every_cell() {
        let mut w = world();
        // Rocks and trees of several sizes and headings around the origin.
        for i in 0..40 {
            let a = i as f64 * 0.7;
            w.obstacles.push(Obstacle {
                kind: if i % 3 == 0 {
                    ObstacleKind::Tree
                } else {
                    ObstacleKind::Rock
                },
                x: (i as f64 * 1.3) % 30.0 - 15.0,
                y: (i as f64 * 2.9) % 30.0 - 15.0,
                z: 0.0,
                yaw: a,
                half_extents: [0.3 + 0.1 * (i % 7) as f64, 0.4 + 0.15 * (i % 5) as f64, 1.0],
            });
        }
        let spec = CropSpec {
            size: 33,
            resolution: 0.7,
        };
        let mut fast = vec![0u8; 33 * 33];
        for k in 0..12 {
            let state = VehicleState {
                position: [k as f64 * 3.0 - 20.0, 5.0 - k as f64, 0.0],
                yaw: k as f64 * 0.55,
                ..Default::default()
            };
            obstacle_crop(&w, &state, &spec, &mut fast);
            let mut slow = vec![0u8; 33 * 33];
            fill(&state, &spec, &mut slow, |x, y| {
                u8::from(!w.heightmap.contains(x, y) || occupied(&w, x, y))
            });
            assert_eq!(fast, slow, "pose {k}");
            assert!(fast.contains(&1), "pose {k} sees obstacles");
        }
    }

    #[test]
    fn semantics_crop_reads_the_patch_under_each_cell_and_marks_off_map() {
        let w = world();
        let spec = CropSpec {
            size: 3,
            resolution: 1.0,
        };
        let state = VehicleState {
            position: [10.0, 0.0, 0.0],
            ..Default::default()
        };
        let mut s = vec![0u8; 9];
        semantics_crop(&w, &state, &spec, &mut s);
        assert_eq!(s[4], Semantic::Grass.id());
        let far = VehicleState {
            position: [64.0, 0.0, 0.0],
            ..Default::default()
        };
        semantics_crop(&w, &far, &spec, &mut s);
        assert_eq!(s[1], 255, "1 m beyond the east edge is off the map");
        assert_eq!(occupancy_grid(&w).iter().filter(|v| **v == 1).count(), 1);
    }
}
