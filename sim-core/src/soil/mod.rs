//! Soil Contact Model (Bekker-Wong pressure-sinkage, Janosi-Hanamoto shear, elastic unloading, damping) on a
//! sparse grid with memory: Chrono's SCM (`SCMTerrain.cpp`, the simulator Verti-Bench runs), term by term as
//! `../shared/reference/scm-chrono-formulation.md` gives it, with the departures listed below.
//!
//! The grid spacing is 0.1 m at full scale (times the world's scale). Each node remembers its plastic sinkage
//! `s_p`, its yield pressure and its accumulated shear displacement `j`; only touched nodes cost memory: nodes live
//! in 8 x 8 tiles taken from a pool allocated once in [`SoilGrid::new`], so the step loop never allocates. If the
//! pool runs out (more than [`TILE_POOL`] tiles touched in one episode, i.e. several kilometres of driving) further
//! nodes behave as fresh soil at every step (no memory) and [`SoilGrid::exhausted`] says so.
//!
//! Per step, for each body (a wheel via [`SoilGrid::wheel_contact`], a track shoe or plate via
//! [`SoilGrid::plate_contact`]) and each node whose vertical ray meets the body (as Chrono's SCM casts rays up
//! through the body's collision shape):
//! 1. the hit: the body's surface point `p` above the node, the body's material velocity `v` there (a wheel's spin
//!    included), the undeformed terrain's unit normal `N` at the node (Chrono's `GetInitNormal`; vertical on level
//!    ground) and the fraction `w` of the node's cell the body covers (1 inside; the nodes at a wheel's or plate's
//!    side edges count for the part of their cell inside the width, so the discrete width equals the body's; see
//!    `contact.rs`);
//! 2. sinkage `s = N_z (h0 - p_z)` (Chrono's `p_hit_offset`), penetration of the current surface `s - s_p`;
//!    elastic trial `sigma = K_e (s - s_p)`; if it exceeds the node's yield pressure, Bekker
//!    `sigma = (k_c / b + k_phi) s^n` holds (`b` the contact patch's `2 A / P`, as Chrono), the yield pressure rises
//!    to it and `s_p = s - sigma / K_e` (so unloading and reloading follow the elastic line until the previous
//!    yield): ruts persist;
//! 3. damping `sigma += -R (v . N)` while the body's material moves into the soil (`v . N < 0`, the spin included:
//!    a slipping wheel's leading arc is damped at `R omega u`); on a wheel over the part of the node's cell (along
//!    the track) inside the rim's contact with the surface it found there and on the side where the rim moves into
//!    the soil, evaluated at that part's midpoint, so the damped area grows continuously as the rim's edge advances
//!    over a cell (the cell just ahead of the edge gets its share too, with the shear its damping pressure carries
//!    but no sinkage or memory: in Chrono the damping is part of every node's `sigma` and so of its shear strength);
//!    [`node::RimPoint::damping`];
//! 4. shear displacement `j += |v_t| t`, `v_t = v - N (v . N)` the slip in the terrain's plane, `t` the step (in the
//!    step a contact begins, the part of it since the body's surface passed the surface it found there); `j` only
//!    grows and is never reset, not when a contact ends nor between the front and rear wheels' passes (Chrono);
//! 5. shear stress `tau = (c + sigma tan phi)(1 - exp(-j / K))` opposite the slip, its direction following the
//!    slip through a short elastic bristle (see the departures);
//! 6. force `delta^2 w (sigma N - tau)` at `p` (Chrono's `m_area = delta^2`, the cell's horizontal area), and its
//!    moment about the body's centre: a wheel's spin is driven by that moment about its axle, so compaction and
//!    damping cost engine torque (the pressure's moment on the leading arc), not drawbar pull.
//!
//! Departures from Chrono, none of which changes the law at driving speeds:
//! - the shear's direction follows the slip through an elastic bristle of length `K / 200` on a rolling wheel
//!   (`K / 20` at rest and on a plate)
//!   (`node::bristle_over_janosi`) instead of flipping the step the slip velocity does, so a body at rest is held
//!   elastically instead of chattering (a parked vehicle on a slope);
//! - forces are returned with their Jacobians (vertical stiffness on the branch each node moves along, damping,
//!   traction and spin stiffness), and the vehicle integrates the wheel's vertical motion and spin linearly
//!   implicitly with them (Chrono applies SCM's forces explicitly and chatters on stiff soils at 5 ms);
//! - a wheel's contact is swept over the step: a node that the rim's lowest point passed over between the wheel's
//!   previous and current position is yielded as deep as that point went (`Hit::swept_bottom`), so ruts of a fast
//!   wheel (12 cm per 4 ms step at 30 m/s) do not depend on which positions the steps catch;
//! - edge nodes count for the part of their cell inside the body's width, and Bekker's `b` comes from the
//!   continuous hull of the contact (`contact::patch_b`), so the contact does not jump between 2 and 3 node rows
//!   as a wheel crosses the grid;
//! - no damping suction: Chrono leaves `-R (v . N)` unclamped, so trailing nodes still in contact (about 1 mm of
//!   elastic rebound behind a rolling wheel, the whole rear half of one spinning in its rut) pull the wheel; here
//!   only material moving into the soil is damped, and the shear strength `c + sigma tan phi` is not negative.
//!   Chrono's unclamped law, tried in r9's development, put about 1 MPa of suction on the rear half of a HMMWV front
//!   wheel spinning at 190 rad/s 44 cm deep in snow, and its reversed shear drove the vehicle backwards down a 24
//!   degree slope at 25 m/s; limited so that the soil carries no tension, the suction moved the grades by under
//!   0.3 deg and the 20 s distances by under 0.5%, so it is left out;
//! - no bulldozing (Chrono moves displaced material to the rut's rim; it adds no force of its own).
//!
//! The contact also returns the Jacobians a vehicle needs to integrate a wheel's spin and vertical motion linearly
//! implicitly ([`SoilContact::traction_stiffness`], [`SoilContact::spin_stiffness`],
//! [`SoilContact::normal_stiffness`], [`SoilContact::normal_damping`]) and the shear capacity the vehicle's shear
//! damping respects ([`SoilContact::shear_capacity`]). [`rig`] is a single-wheel test rig on this model.
//!
//! API (called by the vehicle model once per wheel / track shoe and step, after [`SoilGrid::begin_step`]):
//! [`SoilGrid::new`] (allocates everything), [`SoilGrid::soil_at`] / [`SoilGrid::has_soil_at`] ("no soil here"
//! on rigid patches: use rigid contact), [`SoilGrid::surface_height`] (deformed surface),
//! [`SoilGrid::wheel_contact`] (rigid cylinder), [`SoilGrid::plate_contact`] (flat rectangle),
//! [`SoilGrid::touched_cells`], [`SoilGrid::reset`] (undeformed again, no reallocation).
//!
//! Each cell takes the [`SoilParams`] of the patch it lies in, so one world can hold several soils.

use crate::world::{SoilParams, Surface, World, PATCHES};
use nalgebra::Vector3;
use node::Node;
use std::sync::Arc;

mod contact;
mod ground;
mod node;
pub mod rig;

/// Nodes per tile side.
const TILE: usize = 8;
/// Tiles in the pool (each 64 nodes).
pub const TILE_POOL: usize = 6000;
const NO_TILE: u32 = u32::MAX;

/// Soil force on a contacting body.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SoilContact {
    /// Total force on the body, N (world frame).
    pub force: Vector3<f64>,
    /// Torque about the wheel centre, N m (world frame).
    pub torque: Vector3<f64>,
    /// Sinkage below the undeformed surface, m: a wheel's rim depth under its centre, normal to the undeformed
    /// surface (Wong's `z0`); a plate's deepest pressed node.
    pub sinkage: f64,
    /// Sum of the nodes' normal forces (pressure times the cells' horizontal area, each along the terrain's normal
    /// at its node), N.
    pub normal: f64,
    /// Unit normal of the undeformed ground under the body's centre (a reference frame for the caller).
    pub normal_dir: Vector3<f64>,
    /// For implicit spin integration: d(shear force along the rolling direction)/d(slip velocity of the body's
    /// surface along it), summed over nodes, N s/m. Per node `A t (k_par c^2 + k_perp (1 - c^2))`, `c` the cosine
    /// between the mobilised shear and the rolling direction, `k_par` the slope of `|tau|` against slip along it
    /// (`tau_max / K` elastic, Janosi's `tau_max exp(-h / K) / K` on yield) and `k_perp` across it (`tau_max / K`
    /// elastic, `tau_max |rho| / (K |rho_trial|)` on yield). Slip at speed `v` for one step adds `v t` to `j` (`t`
    /// the step, or in the step a contact begins the part of it since the body reached the node), hence the `t`.
    /// (`K` is the bristle's length while elastic, `node::bristle_over_janosi`, Janosi's `K` on yield.)
    pub traction_stiffness: f64,
    /// For implicit spin integration: `-d(torque about the axle)/d(spin)`, N m s: the shear's share (each node's
    /// traction stiffness times its lever arm squared, `h^2` under a wheel's centre) and the damping's
    /// (`R w delta^2 u^2` over the leading arc's damped cells). Zero for a plate.
    pub spin_stiffness: f64,
    /// For the force a wheel's spin change passes to its vehicle: `d(shear force along the rolling direction)/
    /// d(spin)`, N s (each node's traction stiffness times its lever arm, `h` under a wheel's centre).
    pub spin_force: f64,
    /// `d(damping force along the terrain normal)/d(spin)`, N s: the damping pressure `-R (v . N)` grows with the
    /// spin on the leading arc (`R omega u`), so a vehicle passes the chassis the lift at the wheel's new spin.
    pub spin_lift: f64,
    /// Mohr-Coulomb shear capacity of the contact, `sum (c + sigma tan phi) A` over the pressed nodes, N.
    pub shear_capacity: f64,
    /// For implicit vertical integration: `-d(F_z)/d(z_c)`, the derivative of the vertical soil force with respect to
    /// a vertical displacement `z_c` of the body (all nodes keep their hit, their sinkage changes by `-dz_c`),
    /// towards the soil, N/m: per node `w delta^2 d(sigma)/d(s)` on the branch the node moves along: where the
    /// body's surface moves into the node (`-(v . N) / N_z > 0`, by sinking or by rolling forward over it), the
    /// branch it is on (`K_e` elastic, Bekker's tangent `n sigma / s` plastic); where it moves away or rests, the
    /// elastic line `K_e` (a plastic node unloads elastically), so a node at its yield point under a body at rest
    /// does not chatter between the soft plastic and the stiff elastic branch, and a wheel rolling forward while it
    /// rises a little keeps the soft tangent of the front arc it still yields. Neglects the change of the shear's
    /// vertical part.
    pub normal_stiffness: f64,
    /// For implicit vertical integration: `-d(F_z)/d(v_z)`, N s/m: `w delta^2 R N_z` over the nodes moving into the
    /// soil (the damping pressure `R |v . N|`).
    pub normal_damping: f64,
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
    /// The world whose soil this is (shared with the simulation: its heightmap is the undeformed ground).
    world: Arc<World>,
    /// The undeformed ground at the nodes under bodies (a cache of the world's heightmap).
    ground: ground::GroundCache,
    /// Chrono's ray test height above the surface (0.1 m at full scale): how far above it a wheel's rays still hit.
    test_height: f64,
    /// Below this speed a body is creeping, m/s (0.05 m/s at full scale, Froude-scaled).
    creep_speed: f64,
    step: u64,
    exhausted: bool,
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
            world: Arc::clone(&self.world),
            ground: self.ground.clone(),
            test_height: self.test_height,
            creep_speed: self.creep_speed,
            step: self.step,
            exhausted: self.exhausted,
        }
    }
}

impl SoilGrid {
    /// Builds the soil of a world at the benchmark's node spacing, 0.1 m times the world's scale (allocates
    /// everything up front; a shared world is read, not copied).
    pub fn new(world: impl Into<Arc<World>>) -> SoilGrid {
        let world = world.into();
        let delta = 0.1 * world.scale;
        SoilGrid::with_spacing(world, delta)
    }

    /// Builds the soil of a world with nodes `delta` apart (for resolution studies; allocates everything up front).
    pub fn with_spacing(world: impl Into<Arc<World>>, delta: f64) -> SoilGrid {
        assert!(delta > 0.0, "node spacing must be positive");
        let world: Arc<World> = world.into();
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
            ground: ground::GroundCache::new(any_soil),
            test_height: 0.1 * world.scale,
            creep_speed: 0.05 * world.scale.sqrt(),
            world,
            step: 0,
            exhausted: false,
        }
    }

    /// Node spacing, m.
    pub fn spacing(&self) -> f64 {
        self.delta
    }

    /// Unit normal of the undeformed surface (bilinear heightmap, central differences over one cell).
    pub fn surface_normal(&self, x: f64, y: f64) -> Vector3<f64> {
        self.world.heightmap.surface_normal(x, y)
    }

    /// Soil parameters at a point, `None` on rigid ground.
    pub fn soil_at(&self, x: f64, y: f64) -> Option<SoilParams> {
        let (fx, fy) = self.world.heightmap.grid_coords(x, y);
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

    /// Starts a new physics step.
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
        let h0 = self.world.heightmap.height_bilinear(x, y);
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
}

#[cfg(test)]
mod tests;
