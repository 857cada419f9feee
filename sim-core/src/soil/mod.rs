//! Soil Contact Model (Bekker-Wong pressure-sinkage, Janosi-Hanamoto shear, elastic unloading, damping) on a
//! sparse grid with memory, after Chrono's SCM (physics.md section 2.4).
//!
//! The grid spacing is 0.1 m at full scale (times the world's scale). Each node remembers its plastic sinkage
//! `s_p`, its yield pressure and its accumulated shear displacement `j`; only touched nodes cost memory: nodes live
//! in 8 x 8 tiles taken from a pool allocated once in [`SoilGrid::new`], so the step loop never allocates. If the
//! pool runs out (more than [`TILE_POOL`] tiles touched in one episode, i.e. several kilometres of driving) further
//! nodes behave as fresh soil at every step (no memory) and [`SoilGrid::exhausted`] says so.
//!
//! Per contacting node and step (vertical contact with a rigid wheel cylinder):
//! 1. total sinkage below the undeformed surface `s = h0 - z_wheel`, penetration of the current surface
//!    `s - s_p`;
//! 2. elastic trial `sigma = K_e (s - s_p)`; if it exceeds the node's yield pressure, Bekker
//!    `sigma = (k_c / b + k_phi) s^n` holds, the yield pressure rises to it and `s_p = s - sigma / K_e`
//!    (so unloading and reloading follow the elastic line until the previous yield): ruts persist;
//! 3. damping `sigma += R v_n` while sinking;
//! 4. Janosi shear `tau = (c + sigma tan phi) (1 - exp(-j / K))` opposing the slip velocity, with `j` the slip
//!    distance accumulated while the node stays in contact (reset when contact is lost);
//! 5. force `A (sigma n + tau t)` with `A = delta^2`.
//!
//! API (called by the vehicle model once per wheel / track shoe and step, after [`SoilGrid::begin_step`]):
//! [`SoilGrid::new`] (allocates everything), [`SoilGrid::soil_at`] / [`SoilGrid::has_soil_at`] ("no soil here"
//! on rigid patches: use rigid contact), [`SoilGrid::surface_height`] (deformed surface),
//! [`SoilGrid::wheel_contact`] (rigid cylinder), [`SoilGrid::plate_contact`] (flat rectangle),
//! [`SoilGrid::touched_cells`], [`SoilGrid::reset`] (undeformed again, no reallocation).
//!
//! Each cell takes the [`SoilParams`] of the patch it lies in, so one world can hold several soils.
//! Sinkage, rolling resistance (pressure on the leading arc of a sinking wheel) and traction loss (shear
//! saturating at `c + sigma tan phi`) are not added by hand: they emerge from the per-node law above.

use crate::world::{SoilParams, Surface, World, PATCHES};
use nalgebra::Vector3;

/// Nodes per tile side.
const TILE: usize = 8;
/// Tiles in the pool (each 64 nodes).
pub const TILE_POOL: usize = 6000;
const NO_TILE: u32 = u32::MAX;

#[derive(Clone, Copy, Debug, Default)]
struct Node {
    plastic: f64,
    yield_pressure: f64,
    shear: f64,
    last_step: u64,
}

/// Soil force on a contacting body.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SoilContact {
    /// Total force on the body, N (world frame).
    pub force: Vector3<f64>,
    /// Torque about the wheel centre, N m (world frame).
    pub torque: Vector3<f64>,
    /// Largest sinkage below the undeformed surface, m.
    pub sinkage: f64,
    /// Normal part of the force, N.
    pub normal: f64,
    /// Unit surface normal the pressure acts along.
    pub normal_dir: Vector3<f64>,
    /// d(traction)/d(slip velocity) estimate for implicit wheel-spin integration, N s/m.
    pub traction_stiffness: f64,
    /// Nodes in contact.
    pub nodes: usize,
}

/// A rigid wheel (cylinder) for [`SoilGrid::wheel_contact`].
#[derive(Clone, Copy, Debug)]
pub struct WheelGeometry {
    pub centre: Vector3<f64>,
    /// Unit axle direction (world).
    pub axle: Vector3<f64>,
    pub radius: f64,
    pub width: f64,
    /// Velocity of the centre and angular velocity of the wheel (world).
    pub velocity: Vector3<f64>,
    pub angular_velocity: Vector3<f64>,
}

/// A flat rectangular contact for [`SoilGrid::plate_contact`] (a track shoe, a belt segment, a test plate).
#[derive(Clone, Copy, Debug)]
pub struct PlateGeometry {
    /// Centre of the plate's lower face (world).
    pub centre: Vector3<f64>,
    /// Unit vector along the plate's length, in the face.
    pub forward: Vector3<f64>,
    /// Unit normal of the face, pointing up (away from the soil).
    pub up: Vector3<f64>,
    pub length: f64,
    pub width: f64,
    /// Velocity of the centre and angular velocity of the plate (world).
    pub velocity: Vector3<f64>,
    pub angular_velocity: Vector3<f64>,
}

/// Direction along which a node's pressure pushes a wheel (see [`SoilGrid::set_pressure_direction`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PressureDirection {
    /// Normal of the undeformed ground at the wheel (the default; the vehicle model is validated with it). The
    /// shear acts in the ground's tangent plane; rolling resistance then comes from the shear of the leading arc.
    #[default]
    GroundNormal,
    /// Radial direction of the rim at the node, as Chrono's deformed-mesh normals and Wong-Reece: the pressure
    /// on the leading arc pushes back (compaction resistance) and the shear acts along the rim.
    WheelRadial,
}

/// The soil of a world. A clone keeps the full tile pool capacity, so it never allocates while stepping either.
#[derive(Debug)]
pub struct SoilGrid {
    delta: f64,
    nx: usize,
    ny: usize,
    half_x: f64,
    half_y: f64,
    tiles_x: usize,
    tile_index: Vec<u32>,
    pool: Vec<[Node; TILE * TILE]>,
    /// Tile id (index into `tile_index`) of every pool entry, in pool order (capacity [`TILE_POOL`]).
    pool_tiles: Vec<u32>,
    patch_soil: [Option<SoilParams>; PATCHES * PATCHES],
    heights: crate::world::Heightmap,
    step: u64,
    exhausted: bool,
    pressure: PressureDirection,
}

impl Clone for SoilGrid {
    fn clone(&self) -> Self {
        // `Vec::clone` would shrink the pools to their length: the clone would run out of tiles at once.
        let mut pool = Vec::with_capacity(self.pool.capacity());
        pool.extend_from_slice(&self.pool);
        let mut pool_tiles = Vec::with_capacity(self.pool_tiles.capacity());
        pool_tiles.extend_from_slice(&self.pool_tiles);
        SoilGrid {
            delta: self.delta,
            nx: self.nx,
            ny: self.ny,
            half_x: self.half_x,
            half_y: self.half_y,
            tiles_x: self.tiles_x,
            tile_index: self.tile_index.clone(),
            pool,
            pool_tiles,
            patch_soil: self.patch_soil,
            heights: self.heights.clone(),
            step: self.step,
            exhausted: self.exhausted,
            pressure: self.pressure,
        }
    }
}

impl SoilGrid {
    /// Builds the soil of a world (allocates everything up front).
    pub fn new(world: &World) -> SoilGrid {
        let delta = 0.1 * world.scale;
        let h = &world.heightmap;
        let (half_x, half_y) = (h.half_x(), h.half_y());
        let nx = (2.0 * half_x / delta).ceil() as usize + 1;
        let ny = (2.0 * half_y / delta).ceil() as usize + 1;
        let tiles_x = nx.div_ceil(TILE);
        let tiles_y = ny.div_ceil(TILE);
        let mut patch_soil = [None; PATCHES * PATCHES];
        for (k, p) in world.patches.iter().enumerate().take(PATCHES * PATCHES) {
            if let Surface::Deformable { soil } = p.surface {
                patch_soil[k] = Some(soil);
            }
        }
        let any_soil = patch_soil.iter().any(Option::is_some);
        SoilGrid {
            delta,
            nx,
            ny,
            half_x,
            half_y,
            tiles_x,
            tile_index: vec![NO_TILE; if any_soil { tiles_x * tiles_y } else { 0 }],
            pool: Vec::with_capacity(if any_soil { TILE_POOL } else { 0 }),
            pool_tiles: Vec::with_capacity(if any_soil { TILE_POOL } else { 0 }),
            patch_soil,
            heights: h.clone(),
            step: 0,
            exhausted: false,
            pressure: PressureDirection::GroundNormal,
        }
    }

    /// Chooses the direction of the pressure on wheels ([`PressureDirection`]); plates always use the ground normal.
    pub fn set_pressure_direction(&mut self, d: PressureDirection) {
        self.pressure = d;
    }

    /// Unit normal of the undeformed surface (bilinear heightmap, central differences over one cell).
    pub fn surface_normal(&self, x: f64, y: f64) -> Vector3<f64> {
        self.heights.surface_normal(x, y)
    }

    /// Soil parameters at a point, `None` on rigid ground.
    pub fn soil_at(&self, x: f64, y: f64) -> Option<SoilParams> {
        let (fx, fy) = self.heights.grid_coords(x, y);
        let stride = crate::world::PATCH_STRIDE as f64;
        let pj = ((fx / stride).floor().max(0.0) as usize).min(PATCHES - 1);
        let pi = ((fy / stride).floor().max(0.0) as usize).min(PATCHES - 1);
        self.patch_soil[pi * PATCHES + pj]
    }

    pub fn has_soil_at(&self, x: f64, y: f64) -> bool {
        self.soil_at(x, y).is_some()
    }

    /// Tiles touched so far.
    pub fn touched_tiles(&self) -> usize {
        self.pool.len()
    }

    /// Whether the tile pool ran out (see the module docs).
    pub fn exhausted(&self) -> bool {
        self.exhausted
    }

    /// Starts a new physics step (shear displacement of nodes not touched in the previous step is reset).
    pub fn begin_step(&mut self) {
        self.step += 1;
    }

    /// Back to undeformed soil without reallocating.
    pub fn reset(&mut self) {
        self.tile_index.iter_mut().for_each(|t| *t = NO_TILE);
        self.pool.clear();
        self.pool_tiles.clear();
        self.step = 0;
        self.exhausted = false;
    }

    /// Whether `other` is the soil of a world of the same geometry (grid size and spacing), so memory can be copied.
    pub fn same_grid(&self, other: &SoilGrid) -> bool {
        self.nx == other.nx
            && self.ny == other.ny
            && self.delta == other.delta
            && self.tile_index.len() == other.tile_index.len()
    }

    /// Makes this soil's memory a copy of `src`'s within the square of half side `radius` around `(x, y)`
    /// (whole tiles; `f64::INFINITY` copies everything): the rest is undeformed. Also copies the step counter, so
    /// shear displacement carries over. Cost: the tiles this grid had touched plus the tiles `src` has in the
    /// square; no allocation (the pool was allocated by [`SoilGrid::new`]). Both grids must have the same geometry
    /// ([`SoilGrid::same_grid`]); otherwise nothing is copied and `false` is returned.
    pub fn copy_memory_from(&mut self, src: &SoilGrid, x: f64, y: f64, radius: f64) -> bool {
        if !self.same_grid(src) {
            return false;
        }
        for &t in &self.pool_tiles {
            self.tile_index[t as usize] = NO_TILE;
        }
        self.pool.clear();
        self.pool_tiles.clear();
        self.step = src.step;
        self.exhausted = src.exhausted;
        self.pressure = src.pressure;
        if self.tile_index.is_empty() {
            return true;
        }
        let tiles_y = self.tile_index.len() / self.tiles_x;
        let side = TILE as f64 * self.delta;
        let range = |c: f64, half: f64, n: usize| {
            let lo = ((c - radius + half) / side).floor();
            let hi = ((c + radius + half) / side).floor();
            let lo = if lo.is_nan() { 0.0 } else { lo.max(0.0) };
            let hi = if hi.is_nan() {
                (n - 1) as f64
            } else {
                hi.min((n - 1) as f64)
            };
            (lo as usize, hi as usize)
        };
        let (x0, x1) = range(x, self.half_x, self.tiles_x);
        let (y0, y1) = range(y, self.half_y, tiles_y);
        if x0 > x1 || y0 > y1 {
            return true;
        }
        let area = (x1 - x0 + 1) * (y1 - y0 + 1);
        if area >= src.pool_tiles.len() {
            // Fewer touched tiles than tiles in the square: walk the source's pool.
            for (k, &t) in src.pool_tiles.iter().enumerate() {
                let (tx, ty) = (t as usize % self.tiles_x, t as usize / self.tiles_x);
                if (x0..=x1).contains(&tx) && (y0..=y1).contains(&ty) {
                    self.push_tile(t, &src.pool[k]);
                }
            }
        } else {
            for ty in y0..=y1 {
                for tx in x0..=x1 {
                    let t = ty * self.tiles_x + tx;
                    let k = src.tile_index[t];
                    if k != NO_TILE {
                        self.push_tile(t as u32, &src.pool[k as usize]);
                    }
                }
            }
        }
        true
    }

    fn push_tile(&mut self, t: u32, nodes: &[Node; TILE * TILE]) {
        if self.pool.len() == self.pool.capacity() {
            self.exhausted = true;
            return;
        }
        self.tile_index[t as usize] = self.pool.len() as u32;
        self.pool.push(*nodes);
        self.pool_tiles.push(t);
    }

    fn node_mut(&mut self, i: usize, j: usize) -> Option<&mut Node> {
        let t = (j / TILE) * self.tiles_x + i / TILE;
        if self.tile_index[t] == NO_TILE {
            if self.pool.len() == self.pool.capacity() {
                self.exhausted = true;
                return None;
            }
            self.tile_index[t] = self.pool.len() as u32;
            self.pool.push([Node::default(); TILE * TILE]);
            self.pool_tiles.push(t as u32);
        }
        Some(&mut self.pool[self.tile_index[t] as usize][(j % TILE) * TILE + i % TILE])
    }

    /// Plastic sinkage of the node nearest to a point (0 where untouched or rigid).
    pub fn rut_depth(&self, x: f64, y: f64) -> f64 {
        if self.tile_index.is_empty() {
            return 0.0;
        }
        let i = (((x + self.half_x) / self.delta).round().max(0.0) as usize).min(self.nx - 1);
        let j = (((y + self.half_y) / self.delta).round().max(0.0) as usize).min(self.ny - 1);
        self.plastic_at(i, j)
    }

    /// Current (deformed) surface height: the bilinear heightmap minus the plastic sinkage interpolated bilinearly
    /// between the four surrounding nodes.
    pub fn surface_height(&self, x: f64, y: f64) -> f64 {
        let h0 = self.heights.height_bilinear(x, y);
        if self.tile_index.is_empty() {
            return h0;
        }
        let fx = ((x + self.half_x) / self.delta).clamp(0.0, (self.nx - 1) as f64);
        let fy = ((y + self.half_y) / self.delta).clamp(0.0, (self.ny - 1) as f64);
        let (i, j) = (
            (fx as usize).min(self.nx - 2),
            (fy as usize).min(self.ny - 2),
        );
        let (tx, ty) = (fx - i as f64, fy - j as f64);
        let p = |i: usize, j: usize| self.plastic_at(i, j);
        let rut = (1.0 - ty) * ((1.0 - tx) * p(i, j) + tx * p(i + 1, j))
            + ty * ((1.0 - tx) * p(i, j + 1) + tx * p(i + 1, j + 1));
        h0 - rut
    }

    fn plastic_at(&self, i: usize, j: usize) -> f64 {
        match self.tile_index[(j / TILE) * self.tiles_x + i / TILE] {
            NO_TILE => 0.0,
            t => self.pool[t as usize][(j % TILE) * TILE + i % TILE].plastic,
        }
    }

    /// Nodes that have memory (touched tiles times nodes per tile).
    pub fn touched_cells(&self) -> usize {
        self.pool.len() * TILE * TILE
    }

    /// Node index range covering `[c - reach, c + reach]` along x and y (inclusive).
    fn node_range(&self, c: &Vector3<f64>, reach: f64) -> (usize, usize, usize, usize) {
        let i0 = ((c.x - reach + self.half_x) / self.delta).floor().max(0.0) as usize;
        let i1 =
            (((c.x + reach + self.half_x) / self.delta).ceil().max(0.0) as usize).min(self.nx - 1);
        let j0 = ((c.y - reach + self.half_y) / self.delta).floor().max(0.0) as usize;
        let j1 =
            (((c.y + reach + self.half_y) / self.delta).ceil().max(0.0) as usize).min(self.ny - 1);
        (i0, i1, j0, j1)
    }

    /// SCM update of node `(i, j)` at `(x, y)` pressed by a body whose lowest point above it is at `z_body`, moving
    /// with velocity `v` there; `b` is the Bekker contact width. Adds the node's force to `out` (torque about
    /// `centre`). Returns the node's contribution to the traction stiffness.
    #[allow(clippy::too_many_arguments)]
    fn press_node(
        &mut self,
        (i, j): (usize, usize),
        p: Vector3<f64>,
        v: Vector3<f64>,
        b: f64,
        up: Vector3<f64>,
        centre: &Vector3<f64>,
        dt: f64,
        out: &mut SoilContact,
    ) -> f64 {
        let s = self.heights.height_bilinear(p.x, p.y) - p.z;
        if s <= 0.0 {
            return 0.0;
        }
        let Some(soil) = self.soil_at(p.x, p.y) else {
            return 0.0;
        };
        let step = self.step;
        let area = self.delta * self.delta;
        let Some(node) = self.node_mut(i, j) else {
            return 0.0;
        };
        if s - node.plastic <= 0.0 {
            node.shear = 0.0;
            return 0.0;
        }
        if node.last_step + 1 < step {
            node.shear = 0.0;
        }
        node.last_step = step;
        let k_e = soil.elastic_k.max(soil.k_phi);
        let mut sigma = k_e * (s - node.plastic);
        if sigma > node.yield_pressure {
            let bekker = (soil.k_c / b + soil.k_phi) * s.powf(soil.n);
            sigma = bekker.min(sigma);
            node.yield_pressure = sigma;
            node.plastic = s - sigma / k_e;
        }
        let vn = v.dot(&up);
        if vn < 0.0 {
            sigma -= soil.damping * vn;
        }
        let vt = v - up * vn;
        let slip = vt.norm();
        node.shear += slip * dt;
        let tau_max = soil.cohesion + sigma * soil.friction_angle_deg.to_radians().tan();
        let ratio = (-node.shear / soil.janosi_k).exp();
        let tau = tau_max * (1.0 - ratio);
        let t = if slip > 1e-9 {
            -vt / slip
        } else {
            Vector3::zeros()
        };
        let f = (up * sigma + t * tau) * area;
        out.force += f;
        out.torque += (p - centre).cross(&f);
        out.normal += sigma * area;
        out.sinkage = out.sinkage.max(s);
        out.nodes += 1;
        area * (tau_max * ratio * dt / soil.janosi_k + tau / slip.max(0.05))
    }

    /// Soil force on a rigid wheel, updating the soil's memory. Nodes on rigid patches are skipped.
    pub fn wheel_contact(&mut self, w: &WheelGeometry, dt: f64) -> SoilContact {
        let mut out = SoilContact::default();
        if self.tile_index.is_empty() {
            return out;
        }
        // Pressure acts along the local surface normal and shear in the tangent plane (as Chrono's SCM, whose forces
        // follow the mesh normals), so soft ground on a slope does not hold the vehicle up for free; sinkage is
        // measured vertically, along the nodes' rays.
        let up = self.surface_normal(w.centre.x, w.centre.y);
        out.normal_dir = up;
        let mut fwd = Vector3::z().cross(&w.axle);
        let fwd_norm = fwd.norm();
        if fwd_norm < 1e-9 {
            return out;
        }
        fwd /= fwd_norm;
        let (i0, i1, j0, j1) = self.node_range(&w.centre, w.radius + 0.5 * w.width);
        let mut stiffness = 0.0;
        for j in j0..=j1 {
            for i in i0..=i1 {
                let x = i as f64 * self.delta - self.half_x;
                let y = j as f64 * self.delta - self.half_y;
                let d = Vector3::new(x - w.centre.x, y - w.centre.y, 0.0);
                let a = d.dot(&w.axle);
                let u = d.dot(&fwd);
                if a.abs() > 0.5 * w.width || u.abs() >= w.radius {
                    continue;
                }
                let z_wheel = w.centre.z - (w.radius * w.radius - u * u).sqrt();
                let p = Vector3::new(x, y, z_wheel);
                let v = w.velocity + w.angular_velocity.cross(&(p - w.centre));
                let up = match self.pressure {
                    PressureDirection::GroundNormal => up,
                    PressureDirection::WheelRadial => {
                        // The deformed surface under a node in contact follows the rim.
                        let radial = Vector3::new(-u * fwd.x, -u * fwd.y, w.centre.z - z_wheel);
                        radial / radial.norm()
                    }
                };
                stiffness += self.press_node((i, j), p, v, w.width, up, &w.centre, dt, &mut out);
            }
        }
        out.traction_stiffness = stiffness;
        out
    }

    /// Soil force on a flat rectangular plate (a track shoe or belt segment), updating the soil's memory. The
    /// plate's lower face is the plane through `centre` with normal `plate.up`; nodes whose vertical ray meets the
    /// face inside the `length x width` rectangle are pressed. The Bekker width is the plate's smaller side.
    pub fn plate_contact(&mut self, plate: &PlateGeometry, dt: f64) -> SoilContact {
        let mut out = SoilContact::default();
        if self.tile_index.is_empty() || plate.up.z < 1e-3 {
            return out;
        }
        let up = self.surface_normal(plate.centre.x, plate.centre.y);
        out.normal_dir = up;
        let side = plate.up.cross(&plate.forward);
        let b = plate.length.min(plate.width);
        let (i0, i1, j0, j1) =
            self.node_range(&plate.centre, 0.5 * plate.length.hypot(plate.width));
        let mut stiffness = 0.0;
        for j in j0..=j1 {
            for i in i0..=i1 {
                let x = i as f64 * self.delta - self.half_x;
                let y = j as f64 * self.delta - self.half_y;
                let (dx, dy) = (x - plate.centre.x, y - plate.centre.y);
                // Height of the face above (x, y): on the plane n . (p - c) = 0.
                let dz = -(plate.up.x * dx + plate.up.y * dy) / plate.up.z;
                let d = Vector3::new(dx, dy, dz);
                if d.dot(&plate.forward).abs() > 0.5 * plate.length
                    || d.dot(&side).abs() > 0.5 * plate.width
                {
                    continue;
                }
                let p = plate.centre + d;
                let v = plate.velocity + plate.angular_velocity.cross(&d);
                stiffness += self.press_node((i, j), p, v, b, up, &plate.centre, dt, &mut out);
            }
        }
        out.traction_stiffness = stiffness;
        out
    }
}

#[cfg(test)]
mod tests;
