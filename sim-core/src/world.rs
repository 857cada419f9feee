//! The world data model shared by the generator (`tasks` crate), the simulator and the planners.
//!
//! # Frames and grids
//! - World frame: X east/forward, Y north/left, Z up (Chrono's ISO frame, as the original release), origin at the
//!   centre of the map. Units are SI (m, s, kg, rad) everywhere.
//! - A [`Heightmap`] is a regular grid of `nx * ny` samples with spacing `cell` metres. Sample `(ix, iy)` sits at
//!   `x = (ix - (nx-1)/2) * cell`, `y = (iy - (ny-1)/2) * cell`, and is stored at `heights[iy * nx + ix]`.
//!   `iy` grows with `y` (north). The release's BMP row is therefore `row = ny - 1 - iy`, column `= ix`.
//! - At full scale a map is 129 x 129 samples at 1 m (a 128 m square). A world instantiated at scale `s`
//!   (1, 1/6, 1/10) multiplies every length (cell, heights, obstacle sizes and positions, start/goal, paths) by `s`.
//! - Semantics: the 129 px map is cut into 16 x 16 patches of 9 x 9 px with one pixel of overlap (stride 8 px).
//!   Patch `(pi, pj)` (`pi` = patch row counted along +y, `pj` along +x) covers samples
//!   `ix in 8*pj ..= 8*pj+8`, `iy in 8*pi ..= 8*pi+8`. A point belongs to patch `min(floor(ix_f / 8), 15)`.

use serde::{Deserialize, Serialize};

/// Samples per side of a benchmark map.
pub const MAP_PX: usize = 129;
/// Patches per side of the semantic grid.
pub const PATCHES: usize = 16;
/// Stride of the semantic patches in samples.
pub const PATCH_STRIDE: usize = 8;

/// Elevation level of a world (relief 30 %, 60 %, 100 % of the highest).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ElevationLevel {
    Low,
    Medium,
    High,
}

impl ElevationLevel {
    pub const ALL: [ElevationLevel; 3] = [Self::Low, Self::Medium, Self::High];
    /// Fraction of the highest relief used by this level (paper: 30 / 60 / 100 %).
    pub fn fraction(self) -> f64 {
        match self {
            Self::Low => 0.3,
            Self::Medium => 0.6,
            Self::High => 1.0,
        }
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Low => "low",
            Self::Medium => "medium",
            Self::High => "high",
        }
    }
}

/// Which kinds of surface a world has.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SemanticsKind {
    Rigid,
    Deformable,
    Mixed,
}

impl SemanticsKind {
    pub const ALL: [SemanticsKind; 3] = [Self::Rigid, Self::Deformable, Self::Mixed];
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Rigid => "rigid",
            Self::Deformable => "deformable",
            Self::Mixed => "mixed",
        }
    }
    /// The kind named `name` (the inverse of [`Self::as_str`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.as_str() == name)
    }
}

/// Obstacle density of a world (10 / 20 / 40 rocks).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleDensity {
    Sparse,
    Medium,
    Dense,
}

impl ObstacleDensity {
    pub const ALL: [ObstacleDensity; 3] = [Self::Sparse, Self::Medium, Self::Dense];
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Sparse => "sparse",
            Self::Medium => "medium",
            Self::Dense => "dense",
        }
    }
}

/// The ten semantic classes. The discriminants are the label ids of the original release.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum Semantic {
    Clay = 0,
    Concrete = 1,
    Dirt = 2,
    Grass = 3,
    Gravel = 4,
    Rock = 5,
    Wood = 6,
    Mud = 7,
    Sand = 8,
    Snow = 9,
}

impl Semantic {
    pub const ALL: [Semantic; 10] = [
        Self::Clay,
        Self::Concrete,
        Self::Dirt,
        Self::Grass,
        Self::Gravel,
        Self::Rock,
        Self::Wood,
        Self::Mud,
        Self::Sand,
        Self::Snow,
    ];
    pub const RIGID: [Semantic; 7] = [
        Self::Clay,
        Self::Concrete,
        Self::Dirt,
        Self::Grass,
        Self::Gravel,
        Self::Rock,
        Self::Wood,
    ];
    pub const DEFORMABLE: [Semantic; 3] = [Self::Mud, Self::Sand, Self::Snow];

    pub fn from_id(id: u8) -> Option<Semantic> {
        Self::ALL.get(id as usize).copied()
    }
    pub fn id(self) -> u8 {
        self as u8
    }
    pub fn is_deformable(self) -> bool {
        matches!(self, Self::Mud | Self::Sand | Self::Snow)
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Clay => "clay",
            Self::Concrete => "concrete",
            Self::Dirt => "dirt",
            Self::Grass => "grass",
            Self::Gravel => "gravel",
            Self::Rock => "rock",
            Self::Wood => "wood",
            Self::Mud => "mud",
            Self::Sand => "sand",
            Self::Snow => "snow",
        }
    }
    /// Friction distribution (mean, standard deviation) of a rigid class, as in the release; `None` if deformable.
    pub fn friction_distribution(self) -> Option<(f64, f64)> {
        Some(match self {
            Self::Clay => (0.60, 0.05),
            Self::Concrete => (0.85, 0.08),
            Self::Dirt => (0.60, 0.10),
            Self::Grass => (0.36, 0.07),
            Self::Gravel => (0.55, 0.10),
            Self::Rock => (0.65, 0.08),
            Self::Wood => (0.45, 0.06),
            _ => return None,
        })
    }
    /// Soil Contact Model parameters of a deformable class (snow = Chrono Soft, mud = Mid, sand = Hard/LETE).
    pub fn soil(self) -> Option<SoilParams> {
        match self {
            Self::Snow => Some(SoilParams::SNOW),
            Self::Mud => Some(SoilParams::MUD),
            Self::Sand => Some(SoilParams::SAND),
            _ => None,
        }
    }
}

/// Soil Contact Model (Bekker-Wong / Janosi-Hanamoto) parameters, Chrono's units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoilParams {
    /// Bekker frictional modulus K_phi, Pa/m^n (N/m^(n+2)).
    pub k_phi: f64,
    /// Bekker cohesive modulus K_c, N/m^(n+1).
    pub k_c: f64,
    /// Sinkage exponent n.
    pub n: f64,
    /// Cohesion c, Pa.
    pub cohesion: f64,
    /// Internal friction angle phi, degrees.
    pub friction_angle_deg: f64,
    /// Janosi-Hanamoto shear deformation modulus K, m.
    pub janosi_k: f64,
    /// Elastic (unloading) stiffness K_e, Pa/m.
    pub elastic_k: f64,
    /// Vertical damping R, Pa s/m.
    pub damping: f64,
}

impl SoilParams {
    /// Chrono "Soft" preset, Verti-Bench "snow".
    pub const SNOW: SoilParams = SoilParams {
        k_phi: 0.2e6,
        k_c: 0.0,
        n: 1.1,
        cohesion: 0.0,
        friction_angle_deg: 30.0,
        janosi_k: 0.01,
        elastic_k: 4e7,
        damping: 3e4,
    };
    /// Chrono "Mid" preset, Verti-Bench "mud".
    pub const MUD: SoilParams = SoilParams {
        k_phi: 2e6,
        k_c: 0.0,
        n: 1.1,
        cohesion: 0.0,
        friction_angle_deg: 30.0,
        janosi_k: 0.01,
        elastic_k: 2e8,
        damping: 3e4,
    };
    /// Chrono "Hard" preset (LETE sand), Verti-Bench "sand".
    pub const SAND: SoilParams = SoilParams {
        k_phi: 5.301e6,
        k_c: 1.02e5,
        n: 0.793,
        cohesion: 1.3e3,
        friction_angle_deg: 31.1,
        janosi_k: 0.012,
        elastic_k: 4e8,
        damping: 3e4,
    };
}

/// The physical surface of one semantic patch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Surface {
    /// Rigid ground with a Coulomb friction coefficient (combined with the tyre's as the minimum).
    Rigid { friction: f64 },
    /// Deformable ground simulated with the Soil Contact Model.
    Deformable { soil: SoilParams },
}

/// One semantic patch: its class and its own sampled physical surface.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Patch {
    pub semantic: Semantic,
    pub surface: Surface,
}

/// Restitution of rigid ground, as in the release.
pub const RIGID_RESTITUTION: f64 = 0.01;

/// A regular height grid; see the module docs for the indexing convention.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Heightmap {
    pub nx: usize,
    pub ny: usize,
    /// Sample spacing, m.
    pub cell: f64,
    /// Heights, m, `heights[iy * nx + ix]`.
    pub heights: Vec<f32>,
}

impl Heightmap {
    /// A `MAP_PX x MAP_PX` map at `cell` metres whose height at world point `(x, y)` is `f(x, y)`.
    pub fn from_fn(cell: f64, f: impl Fn(f64, f64) -> f64) -> Heightmap {
        let n = MAP_PX;
        let mut heights = vec![0f32; n * n];
        let half = (n - 1) as f64 / 2.0;
        for iy in 0..n {
            for ix in 0..n {
                heights[iy * n + ix] =
                    f((ix as f64 - half) * cell, (iy as f64 - half) * cell) as f32;
            }
        }
        Heightmap {
            nx: n,
            ny: n,
            cell,
            heights,
        }
    }

    /// Height at sample `(ix, iy)`.
    #[inline]
    pub fn at(&self, ix: usize, iy: usize) -> f64 {
        self.heights[iy * self.nx + ix] as f64
    }
    /// Half extent of the map along x, m.
    pub fn half_x(&self) -> f64 {
        (self.nx - 1) as f64 * self.cell * 0.5
    }
    /// Half extent of the map along y, m.
    pub fn half_y(&self) -> f64 {
        (self.ny - 1) as f64 * self.cell * 0.5
    }
    /// Continuous grid coordinates `(fx, fy)` of a world point (sample units, not clamped).
    #[inline]
    pub fn grid_coords(&self, x: f64, y: f64) -> (f64, f64) {
        (
            x / self.cell + (self.nx - 1) as f64 * 0.5,
            y / self.cell + (self.ny - 1) as f64 * 0.5,
        )
    }
    /// World position of sample `(ix, iy)`.
    #[inline]
    pub fn sample_position(&self, ix: usize, iy: usize) -> (f64, f64) {
        (
            (ix as f64 - (self.nx - 1) as f64 * 0.5) * self.cell,
            (iy as f64 - (self.ny - 1) as f64 * 0.5) * self.cell,
        )
    }
    /// The 8-connected neighbours of sample index `idx` (`iy * nx + ix`) that lie on the grid, each with its step
    /// length in cells (1 or sqrt 2), in a fixed order (E, W, N, S, NE, SE, NW, SW): the moves of the grid
    /// searches (the task set's A*, the MPPI-6 cost-to-go). Allocates nothing.
    pub fn grid_neighbours(&self, idx: usize) -> impl Iterator<Item = (usize, f64)> {
        const MOVES: [(i64, i64); 8] = [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ];
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let (x, y) = ((idx % self.nx) as i64, (idx / self.nx) as i64);
        MOVES.into_iter().filter_map(move |(dx, dy)| {
            let (qx, qy) = (x + dx, y + dy);
            (qx >= 0 && qy >= 0 && qx < nx && qy < ny).then(|| {
                let step = if dx != 0 && dy != 0 {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                };
                ((qy * nx + qx) as usize, step)
            })
        })
    }
    /// Whether a world point lies on the map.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        x.abs() <= self.half_x() && y.abs() <= self.half_y()
    }
    /// Bilinearly interpolated height, clamped to the map edge.
    pub fn height_bilinear(&self, x: f64, y: f64) -> f64 {
        let (fx, fy) = self.grid_coords(x, y);
        let fx = fx.clamp(0.0, (self.nx - 1) as f64);
        let fy = fy.clamp(0.0, (self.ny - 1) as f64);
        // fx, fy >= 0 here, so truncation is floor (and avoids a libm call on baseline x86-64).
        let ix = (fx as usize).min(self.nx - 2);
        let iy = (fy as usize).min(self.ny - 2);
        let tx = fx - ix as f64;
        let ty = fy - iy as f64;
        let h00 = self.at(ix, iy);
        let h10 = self.at(ix + 1, iy);
        let h01 = self.at(ix, iy + 1);
        let h11 = self.at(ix + 1, iy + 1);
        (h00 * (1.0 - tx) + h10 * tx) * (1.0 - ty) + (h01 * (1.0 - tx) + h11 * tx) * ty
    }
    /// Unit normal of the bilinear surface (central differences over half a cell each way).
    pub fn surface_normal(&self, x: f64, y: f64) -> nalgebra::Vector3<f64> {
        let e = 0.5 * self.cell;
        let gx = (self.height_bilinear(x + e, y) - self.height_bilinear(x - e, y)) / (2.0 * e);
        let gy = (self.height_bilinear(x, y + e) - self.height_bilinear(x, y - e)) / (2.0 * e);
        nalgebra::Vector3::new(-gx, -gy, 1.0).normalize()
    }

    /// Returns a copy with every length multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Heightmap {
        Heightmap {
            nx: self.nx,
            ny: self.ny,
            cell: self.cell * s,
            heights: self
                .heights
                .iter()
                .map(|h| (*h as f64 * s) as f32)
                .collect(),
        }
    }
}

/// Kind of an obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ObstacleKind {
    /// A boulder: a convex, box-like rock of `half_extents` (release: 4.4 x 4.4 x 3.8 m times scale U(0.7, 1.2)).
    Rock,
    /// A tree: a vertical cylinder trunk of radius `half_extents[0]` and height `2 * half_extents[2]`.
    Tree,
}

/// A rigid obstacle standing on the terrain.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Obstacle {
    pub kind: ObstacleKind,
    /// Centre of the footprint, m.
    pub x: f64,
    pub y: f64,
    /// Terrain height at the centre (the obstacle's base), m.
    pub z: f64,
    /// Rotation about +z, rad.
    pub yaw: f64,
    /// Half sizes along the obstacle's local x, y, z, m.
    pub half_extents: [f64; 3],
}

/// A fully specified world, at one scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct World {
    pub id: u32,
    /// Scale factor relative to the full-scale world (1, 1/6, 1/10).
    pub scale: f64,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    pub heightmap: Heightmap,
    /// `PATCHES * PATCHES` patches, `patches[pi * PATCHES + pj]`, `pi` along +y, `pj` along +x.
    pub patches: Vec<Patch>,
    pub obstacles: Vec<Obstacle>,
}

impl World {
    /// A world of one surface everywhere and no obstacles around a heightmap (id 1, full scale, factors low /
    /// rigid or deformable / sparse): the building block of hand-made test terrains and custom worlds.
    pub fn uniform(heightmap: Heightmap, semantic: Semantic, surface: Surface) -> World {
        let semantics = if matches!(surface, Surface::Deformable { .. }) {
            SemanticsKind::Deformable
        } else {
            SemanticsKind::Rigid
        };
        World {
            id: 1,
            scale: 1.0,
            level: ElevationLevel::Low,
            semantics,
            density: ObstacleDensity::Sparse,
            heightmap,
            patches: vec![Patch { semantic, surface }; PATCHES * PATCHES],
            obstacles: Vec::new(),
        }
    }

    /// Index into `patches` of the patch under a world point (clamped to the map).
    pub fn patch_index_at(&self, x: f64, y: f64) -> usize {
        let (fx, fy) = self.heightmap.grid_coords(x, y);
        // Clamped to >= 0 first, so truncation is floor.
        let pj = ((fx / PATCH_STRIDE as f64).max(0.0) as usize).min(PATCHES - 1);
        let pi = ((fy / PATCH_STRIDE as f64).max(0.0) as usize).min(PATCHES - 1);
        pi * PATCHES + pj
    }
    /// The patch under a world point.
    pub fn patch_at(&self, x: f64, y: f64) -> &Patch {
        &self.patches[self.patch_index_at(x, y)]
    }
    /// Returns a copy with every length multiplied by `s` (relative to the current scale).
    pub fn scaled(&self, s: f64) -> World {
        World {
            id: self.id,
            scale: self.scale * s,
            level: self.level,
            semantics: self.semantics,
            density: self.density,
            heightmap: self.heightmap.scaled(s),
            patches: self.patches.clone(),
            obstacles: self
                .obstacles
                .iter()
                .map(|o| Obstacle {
                    x: o.x * s,
                    y: o.y * s,
                    z: o.z * s,
                    half_extents: o.half_extents.map(|h| h * s),
                    ..*o
                })
                .collect(),
        }
    }
}

/// One navigation task: drive from `start` to `goal` in a world.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Task {
    pub world_id: u32,
    /// 0..10 within the world.
    pub index: u32,
    pub start: [f64; 2],
    pub goal: [f64; 2],
    /// Global path from start to goal (A* on the obstacle grid), world coordinates, m.
    pub path: Vec<[f64; 2]>,
}

impl Task {
    /// Stable task id, e.g. `w017-t3`.
    pub fn id(&self) -> String {
        contracts::TaskId::new(self.world_id, self.index).to_string()
    }
    /// Returns a copy with every length multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Task {
        Task {
            world_id: self.world_id,
            index: self.index,
            start: self.start.map(|v| v * s),
            goal: self.goal.map(|v| v * s),
            path: self.path.iter().map(|p| p.map(|v| v * s)).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_neighbours_stay_on_the_grid_with_diagonal_steps_of_sqrt_2() {
        let h = Heightmap::from_fn(1.0, |_, _| 0.0);
        let n = h.nx;
        // Interior sample: all 8, in the fixed order E, W, N, S, NE, SE, NW, SW.
        let i = 5 * n + 7;
        let got: Vec<(usize, f64)> = h.grid_neighbours(i).collect();
        let r2 = std::f64::consts::SQRT_2;
        assert_eq!(
            got,
            vec![
                (i + 1, 1.0),
                (i - 1, 1.0),
                (i + n, 1.0),
                (i - n, 1.0),
                (i + n + 1, r2),
                (i - n + 1, r2),
                (i + n - 1, r2),
                (i - n - 1, r2),
            ]
        );
        // Corners have three neighbours, edges five; every neighbour is adjacent and on the grid.
        assert_eq!(h.grid_neighbours(0).count(), 3);
        assert_eq!(h.grid_neighbours(n * n - 1).count(), 3);
        assert_eq!(h.grid_neighbours(n / 2).count(), 5);
        for (q, step) in h.grid_neighbours(n - 1) {
            assert!(q < n * n);
            let (dx, dy) = ((q % n).abs_diff(n - 1), q / n);
            assert!(dx <= 1 && dy <= 1);
            assert_eq!(step, if dx == 1 && dy == 1 { r2 } else { 1.0 });
        }
    }
}
