//! The world data model shared by the generator (`tasks` crate), the simulator and the planners: [`World`] (here,
//! with its obstacles and [`Task`]s), its ground's classes and physical surfaces (`surface`) and its [`Heightmap`]
//! (`heightmap`).
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

mod heightmap;
mod surface;

pub use heightmap::Heightmap;
pub use surface::{
    ElevationLevel, ObstacleDensity, Patch, Semantic, SemanticsKind, SoilParams, Surface,
    RIGID_RESTITUTION,
};

use serde::{Deserialize, Serialize};

/// Samples per side of a benchmark map.
pub const MAP_PX: usize = 129;
/// Patches per side of the semantic grid.
pub const PATCHES: usize = 16;
/// Stride of the semantic patches in samples.
pub const PATCH_STRIDE: usize = 8;
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
