//! The elevation map built online, as a vehicle with a range sensor builds it: on the world's own grid, every cell
//! unknown until the sensor has seen it, each measurement noisy with a variance growing with range
//! (`k d^2`, elevation_mapping_cupy's point variance), repeated views fused by inverse variance (a 1-D Kalman update
//! per cell).
//!
//! A scan is a radial sweep from the sensor (the classic viewshed): rays [`SPACING`] cells apart at the range's end,
//! marched outward [`SPACING`] cells at a time, keeping the steepest elevation angle seen so far; a point is visible
//! when its own angle is at least that steep, so cells behind crests and obstacles stay unknown. At that spacing
//! every cell within range has a sample within half a cell of its centre, so no visible cell is missed. Obstacles occlude with their tops.
//! The cost of a scan grows with the range, not the map: the map is built incrementally.

use crate::rng::normal;
use rand_chacha::ChaCha8Rng;
use sim_core::world::World;

/// Spacing of a scan's samples, in cells, along a ray and between rays at the range's end (below `1/sqrt(2)`).
pub const SPACING: f64 = 0.7;

/// What the planner gets: the fused heights, their variances and which cells are known.
#[derive(Clone, Debug, PartialEq)]
pub struct OnlineMap {
    pub nx: usize,
    pub ny: usize,
    /// Metres between samples (the world's own grid).
    pub cell: f64,
    /// Fused height per cell, m (`NaN` where unknown), stored like `Heightmap::heights`.
    pub height: Vec<f32>,
    /// Variance of the fused height, m^2 (infinite where unknown).
    pub variance: Vec<f32>,
}

impl OnlineMap {
    /// A map of `world`'s grid with every cell unknown.
    pub fn unknown(world: &World) -> OnlineMap {
        let h = &world.heightmap;
        OnlineMap {
            nx: h.nx,
            ny: h.ny,
            cell: h.cell,
            height: vec![f32::NAN; h.nx * h.ny],
            variance: vec![f32::INFINITY; h.nx * h.ny],
        }
    }

    pub fn is_known(&self, idx: usize) -> bool {
        self.variance[idx].is_finite()
    }

    /// How many cells are known.
    pub fn known_count(&self) -> usize {
        self.variance.iter().filter(|v| v.is_finite()).count()
    }

    /// Fuses one measurement `z` of variance `var` (> 0; 0 sets the cell exactly) into cell `idx`.
    fn fuse(&mut self, idx: usize, z: f64, var: f64) {
        let (m, v) = (f64::from(self.height[idx]), f64::from(self.variance[idx]));
        let (m, v) = if !v.is_finite() || var <= 0.0 {
            (z, var.max(0.0))
        } else if v <= 0.0 {
            (m, 0.0)
        } else {
            let w = v / (v + var);
            (m + w * (z - m), v * var / (v + var))
        };
        self.height[idx] = m as f32;
        self.variance[idx] = v as f32;
    }
}

/// The sensor's geometry at one scan, at the world's scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scan {
    /// Sensor position in the world frame, m.
    pub origin: [f64; 3],
    /// Heading the field of view is centred on, rad.
    pub heading: f64,
    pub range: f64,
    /// Full horizontal field of view, rad (2 pi: all around).
    pub fov: f64,
    /// Measurement variance factor: `k d^2`.
    pub noise_k: f64,
}

impl Scan {
    /// Whether the direction to (x, y) lies in the field of view.
    pub fn in_view(&self, x: f64, y: f64) -> bool {
        if self.fov >= std::f64::consts::TAU {
            return true;
        }
        let a = (y - self.origin[1]).atan2(x - self.origin[0]) - self.heading;
        let a = (a + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU) - std::f64::consts::PI;
        a.abs() <= self.fov / 2.0
    }
}

/// One episode's mapper: the map, the occluding surface (terrain raised to obstacle tops) and a per-scan stamp so a
/// cell is fused at most once per scan.
pub struct Mapper {
    pub map: OnlineMap,
    /// Terrain height with obstacle tops, per grid sample.
    surface: Vec<f32>,
    stamp: Vec<u32>,
    scans: u32,
    /// Each ray's steepest slope so far (`+inf`: it left the map), reused across scans.
    steepest: Vec<f64>,
    /// `1 / r` of each step of a scan, reused across scans.
    inv_r: Vec<f64>,
    rng: ChaCha8Rng,
}

impl Mapper {
    pub fn new(world: &World, rng: ChaCha8Rng) -> Mapper {
        let h = &world.heightmap;
        let mut surface = h.heights.clone();
        for o in &world.obstacles {
            let top = (o.z + 2.0 * o.half_extents[2]) as f32;
            let reach = o.half_extents[0].hypot(o.half_extents[1]);
            let (gx, gy) = h.grid_coords(o.x, o.y);
            let r = (reach / h.cell).ceil() as i64 + 1;
            for iy in (gy.round() as i64 - r)..=(gy.round() as i64 + r) {
                for ix in (gx.round() as i64 - r)..=(gx.round() as i64 + r) {
                    if ix < 0 || iy < 0 || ix as usize >= h.nx || iy as usize >= h.ny {
                        continue;
                    }
                    let (x, y) = h.sample_position(ix as usize, iy as usize);
                    if sim_core::observe::occupied_by(o, x, y) {
                        let s = &mut surface[iy as usize * h.nx + ix as usize];
                        *s = s.max(top);
                    }
                }
            }
        }
        Mapper {
            map: OnlineMap::unknown(world),
            stamp: vec![0; surface.len()],
            surface,
            scans: 0,
            steepest: Vec::new(),
            inv_r: Vec::new(),
            rng,
        }
    }

    /// One scan: fuses a measurement of every visible cell within range and returns how many were measured.
    ///
    /// The sweep runs in bands of range: each band has twice the rays of the one inside it, each new ray starting
    /// from its parent's steepest angle, and a band ends where its rays are [`SPACING`] cells apart; so the samples
    /// are about one per `SPACING^2` cells of area, not one per ray and step of the outermost band.
    pub fn scan(&mut self, world: &World, scan: &Scan) -> usize {
        let h = &world.heightmap;
        self.scans += 1;
        let step = SPACING * h.cell;
        let fov = scan.fov.min(std::f64::consts::TAU);
        let steps = (scan.range / step).floor() as usize;
        let first = if fov >= std::f64::consts::TAU {
            0.0
        } else {
            scan.heading - fov / 2.0
        };
        let [sx, sy, sz] = scan.origin;
        let (half_x, half_y) = ((h.nx - 1) as f64 * 0.5, (h.ny - 1) as f64 * 0.5);
        let (nx, ny, inv_cell) = (h.nx as f64, h.ny as f64, 1.0 / h.cell);
        let mut inv_r = std::mem::take(&mut self.inv_r);
        inv_r.clear();
        inv_r.extend((0..=steps).map(|j| 1.0 / (j.max(1) as f64 * step)));
        let mut rays = ((2.0 * fov).ceil() as usize).max(2);
        self.steepest.clear();
        self.steepest.resize(rays, f64::NEG_INFINITY);
        let mut measured = 0;
        let mut j = 1;
        while j <= steps {
            // This band's last step: where its rays are `step` apart.
            let end = ((rays as f64 / fov).floor() as usize).clamp(j, steps);
            for k in 0..rays {
                let mut steepest = self.steepest[k];
                if steepest == f64::INFINITY {
                    continue;
                }
                let a = first + fov * (k as f64 + 0.5) / rays as f64;
                let (dy, dx) = a.sin_cos();
                // Grid coordinates (plus a half, so truncation rounds) along the ray, one step at a time.
                let (gx0, gy0) = (sx * inv_cell + half_x + 0.5, sy * inv_cell + half_y + 0.5);
                let (ux, uy) = (dx * step * inv_cell, dy * step * inv_cell);
                for (jj, inv_r) in inv_r.iter().enumerate().take(end + 1).skip(j) {
                    let (fx, fy) = (gx0 + jj as f64 * ux, gy0 + jj as f64 * uy);
                    if !(fx >= 0.0 && fy >= 0.0 && fx < nx && fy < ny) {
                        // Off the map: this ray and its children are done.
                        steepest = f64::INFINITY;
                        break;
                    }
                    let (ix, iy) = (fx as usize, fy as usize);
                    let idx = iy * h.nx + ix;
                    let slope = (f64::from(self.surface[idx]) - sz) * inv_r;
                    if slope < steepest {
                        continue;
                    }
                    steepest = slope;
                    if self.stamp[idx] != self.scans {
                        self.stamp[idx] = self.scans;
                        self.measure(h, ix, iy, scan);
                        measured += 1;
                    }
                }
                self.steepest[k] = steepest;
            }
            j = end + 1;
            if j <= steps {
                // Each ray splits in two, both starting from its horizon.
                self.steepest.resize(2 * rays, f64::NEG_INFINITY);
                for k in (0..rays).rev() {
                    let s = self.steepest[k];
                    self.steepest[2 * k] = s;
                    self.steepest[2 * k + 1] = s;
                }
                rays *= 2;
            }
        }
        self.inv_r = inv_r;
        measured
    }

    /// Fuses one measurement of cell `idx`, its variance `k d^2` from the sensor to the cell's centre.
    fn measure(&mut self, h: &sim_core::world::Heightmap, ix: usize, iy: usize, scan: &Scan) {
        let idx = iy * h.nx + ix;
        let truth = f64::from(h.heights[idx]);
        if scan.noise_k <= 0.0 {
            self.map.fuse(idx, truth, 0.0);
            return;
        }
        let [sx, sy, sz] = scan.origin;
        let (cx, cy) = h.sample_position(ix, iy);
        let d2 = (cx - sx).powi(2) + (cy - sy).powi(2) + (truth - sz).powi(2);
        let var = scan.noise_k * d2;
        let z = truth + var.sqrt() * normal(&mut self.rng);
        self.map.fuse(idx, z, var);
    }
}
