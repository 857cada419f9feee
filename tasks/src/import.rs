//! Importer of the original Verti-Bench release (`envs/data/BenchMaps/sampled_maps` of RobotiXX/verti_bench).
//!
//! Reads `Worlds/N.bmp` (129 x 129, gray / 255 mapped to `[min_height, max_height]`, row 0 = north) and
//! `Configs/Final/configN_L.yaml` (factors, 10 start/goal pairs, 256 patch textures with class and friction,
//! rocks and trees), checks `labelsN_L.npy` (129 x 129 label ids) when present, and builds our worlds: heights,
//! per-patch classes and friction (deformable classes take their SCM set), obstacles (rocks as 4.4 x 4.4 x 3.8 m
//! boxes times their scale, trees as 0.5 m trunks) and the start/goal pairs. Global paths are planned with our A*
//! (the release plans at run time). Release patch `index [i, j]` (i grows southward) becomes our `pi = 15 - i`,
//! `pj = j`.

use crate::format::WorldRecord;
use crate::obstacles::{ROCK_HALF_EXTENTS, TREE_HALF_HEIGHT, TREE_RADIUS};
use crate::path::{occupancy, plan_on_grid, DEFAULT_INFLATION};
use crate::{heightmap_io, TasksError};
use serde::Deserialize;
use sim_core::world::{
    ElevationLevel, Heightmap, Obstacle, ObstacleDensity, ObstacleKind, Patch, Semantic,
    SemanticsKind, Surface, Task, World, MAP_PX, PATCHES,
};
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
struct Config {
    terrain: TerrainCfg,
    positions: Vec<PositionCfg>,
    terrain_type: String,
    obstacle_density: String,
    textures: Vec<TextureCfg>,
    #[serde(default)]
    obstacles: ObstaclesCfg,
}

#[derive(Deserialize)]
struct TerrainCfg {
    min_height: f64,
    max_height: f64,
    difficulty: String,
}

#[derive(Deserialize)]
struct PositionCfg {
    start: Vec<f64>,
    goal: Vec<f64>,
}

#[derive(Deserialize)]
struct TextureCfg {
    index: [usize; 2],
    terrain_type: String,
    #[serde(default)]
    friction: Option<f64>,
}

#[derive(Deserialize, Default)]
struct ObstaclesCfg {
    #[serde(default)]
    rocks: Vec<RockCfg>,
    #[serde(default)]
    trees: Vec<TreeCfg>,
}

#[derive(Deserialize)]
struct Xyz {
    x: f64,
    y: f64,
}

#[derive(Deserialize)]
struct RockCfg {
    position: Xyz,
    scale: f64,
}

#[derive(Deserialize)]
struct TreeCfg {
    position: Xyz,
}

/// One world found in a release directory.
#[derive(Clone, Debug, PartialEq)]
pub struct ReleaseWorld {
    pub id: u32,
    pub config: PathBuf,
    pub bmp: PathBuf,
    pub labels: Option<PathBuf>,
}

/// Finds the worlds of a release directory (`.../sampled_maps`, or a clone's root).
pub fn discover(root: &Path) -> Result<Vec<ReleaseWorld>, TasksError> {
    let base = [
        root.to_path_buf(),
        root.join("envs/data/BenchMaps/sampled_maps"),
        root.join("BenchMaps/sampled_maps"),
    ]
    .into_iter()
    .find(|p| p.join("Configs/Final").is_dir())
    .ok_or_else(|| {
        TasksError::field(
            root,
            "Configs/Final",
            "not a Verti-Bench sampled_maps directory",
        )
    })?;
    let cfg_dir = base.join("Configs/Final");
    let entries = std::fs::read_dir(&cfg_dir).map_err(|e| TasksError::io(&cfg_dir, e))?;
    let mut worlds = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| TasksError::io(&cfg_dir, e))?;
        let name = entry.file_name().to_string_lossy().to_string();
        let Some(stem) = name
            .strip_prefix("config")
            .and_then(|s| s.strip_suffix(".yaml"))
        else {
            continue;
        };
        let Some((id, level)) = stem.split_once('_') else {
            continue;
        };
        let Ok(id) = id.parse::<u32>() else { continue };
        let labels = cfg_dir.join(format!("labels{id}_{level}.npy"));
        worlds.push(ReleaseWorld {
            id,
            config: entry.path(),
            bmp: base.join(format!("Worlds/{id}.bmp")),
            labels: labels.exists().then_some(labels),
        });
    }
    worlds.sort_by_key(|w| w.id);
    if worlds.is_empty() {
        return Err(TasksError::field(
            &cfg_dir,
            "configN_L.yaml",
            "no world configs found",
        ));
    }
    Ok(worlds)
}

fn class(name: &str) -> Option<Semantic> {
    Semantic::ALL.into_iter().find(|s| s.as_str() == name)
}

/// Imports one release world with its tasks (paths planned for the default vehicle).
pub fn import_world(w: &ReleaseWorld) -> Result<WorldRecord, TasksError> {
    let path = &w.config;
    let text = std::fs::read_to_string(path).map_err(|e| TasksError::io(path, e))?;
    let cfg: Config = serde_norway::from_str(&text).map_err(|e| TasksError::Yaml {
        path: path.clone(),
        message: e.to_string(),
    })?;
    let (level, semantics, density) = factors(&cfg, path)?;
    let heightmap = heights(w, &cfg, path)?;
    let patches = patches(&cfg, path)?;
    let obstacles = obstacles(&cfg, &heightmap, path)?;
    let world = World {
        id: w.id,
        scale: 1.0,
        level,
        semantics,
        density,
        heightmap,
        patches,
        obstacles,
    };
    let tasks = tasks(&cfg, &world, path)?;
    Ok(WorldRecord {
        world,
        tasks,
        terrain: None,
    })
}

/// An error in field `field` of the world config at `path`.
fn bad(path: &Path, field: &str, msg: String) -> TasksError {
    TasksError::field(path, field, msg)
}

/// The world's elevation level, semantics kind and obstacle density.
fn factors(
    cfg: &Config,
    path: &Path,
) -> Result<(ElevationLevel, SemanticsKind, ObstacleDensity), TasksError> {
    let level = match cfg.terrain.difficulty.as_str() {
        "low" => ElevationLevel::Low,
        "mid" | "medium" => ElevationLevel::Medium,
        "high" => ElevationLevel::High,
        other => {
            let msg = format!("unknown level `{other}`");
            return Err(bad(path, "terrain.difficulty", msg));
        }
    };
    let semantics = SemanticsKind::parse(&cfg.terrain_type).map_err(|_| {
        let msg = format!("unknown kind `{}`", cfg.terrain_type);
        bad(path, "terrain_type", msg)
    })?;
    let density = match cfg.obstacle_density.as_str() {
        "sparse" => ObstacleDensity::Sparse,
        "medium" => ObstacleDensity::Medium,
        "dense" => ObstacleDensity::Dense,
        other => {
            let msg = format!("unknown density `{other}`");
            return Err(bad(path, "obstacle_density", msg));
        }
    };
    Ok((level, semantics, density))
}

/// The heightmap of `Worlds/N.bmp` in the config's height range, and the label image's check when it has one.
fn heights(w: &ReleaseWorld, cfg: &Config, path: &Path) -> Result<Heightmap, TasksError> {
    let (lo, hi) = (cfg.terrain.min_height, cfg.terrain.max_height);
    let lim = crate::check::MAX_ABS_HEIGHT;
    if !(lo.is_finite() && hi.is_finite() && hi > lo && lo.abs() <= lim && hi.abs() <= lim) {
        let msg = format!("height range [{lo}, {hi}] is empty or not within [-{lim}, {lim}] m");
        return Err(bad(path, "terrain.max_height", msg));
    }
    let heightmap = heightmap_io::load_heightmap(&w.bmp, 1.0, lo, hi)?;
    if heightmap.nx != MAP_PX || heightmap.ny != MAP_PX {
        return Err(TasksError::Image {
            path: w.bmp.clone(),
            message: format!(
                "size {} x {}, expected {MAP_PX} x {MAP_PX}",
                heightmap.nx, heightmap.ny
            ),
        });
    }
    if let Some(labels) = &w.labels {
        let (lw, lh, values, _) = heightmap_io::read_samples(labels)?;
        if (lw, lh) != (MAP_PX, MAP_PX)
            || values
                .iter()
                .any(|v| Semantic::from_id(*v as u8).is_none() || *v < 0.0)
        {
            return Err(TasksError::Image {
                path: labels.clone(),
                message: "expected 129 x 129 label ids 0..=9".into(),
            });
        }
    }
    Ok(heightmap)
}

/// The 16 x 16 patches: each texture's class, and its friction (rigid) or soil set (deformable).
fn patches(cfg: &Config, path: &Path) -> Result<Vec<Patch>, TasksError> {
    if cfg.textures.len() != PATCHES * PATCHES {
        let msg = format!(
            "{} entries, expected {}",
            cfg.textures.len(),
            PATCHES * PATCHES
        );
        return Err(bad(path, "textures", msg));
    }
    let mut patches: Vec<Option<Patch>> = vec![None; PATCHES * PATCHES];
    for (k, t) in cfg.textures.iter().enumerate() {
        let field = format!("textures[{k}]");
        let [i, j] = t.index;
        if i >= PATCHES || j >= PATCHES {
            let msg = format!("[{i}, {j}] is off the 16 x 16 grid");
            return Err(bad(path, &format!("{field}.index"), msg));
        }
        let semantic = class(&t.terrain_type).ok_or_else(|| {
            let msg = format!("unknown class `{}`", t.terrain_type);
            bad(path, &format!("{field}.terrain_type"), msg)
        })?;
        let surface = match (semantic.soil(), t.friction) {
            (Some(soil), _) => Surface::Deformable { soil },
            (None, Some(f)) if (0.0..=2.0).contains(&f) => Surface::Rigid { friction: f },
            (None, f) => {
                let msg = format!("{f:?} is missing or out of range");
                return Err(bad(path, &format!("{field}.friction"), msg));
            }
        };
        patches[(PATCHES - 1 - i) * PATCHES + j] = Some(Patch { semantic, surface });
    }
    patches
        .into_iter()
        .enumerate()
        .map(|(k, p)| p.ok_or_else(|| bad(path, "textures", format!("patch {k} is missing"))))
        .collect()
}

/// Rocks as boxes of their scale and trees as trunks, standing on the ground.
fn obstacles(
    cfg: &Config,
    heightmap: &Heightmap,
    path: &Path,
) -> Result<Vec<Obstacle>, TasksError> {
    let mut obstacles = Vec::new();
    for (k, r) in cfg.obstacles.rocks.iter().enumerate() {
        if !(r.scale.is_finite() && r.scale > 0.0) {
            let msg = format!("{} is not positive", r.scale);
            return Err(bad(path, &format!("obstacles.rocks[{k}].scale"), msg));
        }
        obstacles.push(Obstacle {
            kind: ObstacleKind::Rock,
            x: r.position.x,
            y: r.position.y,
            z: heightmap.height_bilinear(r.position.x, r.position.y),
            yaw: 0.0,
            half_extents: ROCK_HALF_EXTENTS.map(|h| h * r.scale),
        });
    }
    for t in &cfg.obstacles.trees {
        obstacles.push(Obstacle {
            kind: ObstacleKind::Tree,
            x: t.position.x,
            y: t.position.y,
            z: heightmap.height_bilinear(t.position.x, t.position.y),
            yaw: 0.0,
            half_extents: [TREE_RADIUS, TREE_RADIUS, TREE_HALF_HEIGHT],
        });
    }
    Ok(obstacles)
}

/// The start/goal pairs with their global paths (A* on the obstacle grid, or over the open map).
fn tasks(cfg: &Config, world: &World, path: &Path) -> Result<Vec<Task>, TasksError> {
    let blocked = occupancy(world, DEFAULT_INFLATION);
    let mut tasks = Vec::new();
    for (k, p) in cfg.positions.iter().enumerate() {
        let field = format!("positions[{k}]");
        if p.start.len() < 2 || p.goal.len() < 2 {
            return Err(bad(path, &field, "start and goal need x and y".into()));
        }
        let (s, g) = ([p.start[0], p.start[1]], [p.goal[0], p.goal[1]]);
        if !world.heightmap.contains(s[0], s[1]) || !world.heightmap.contains(g[0], g[1]) {
            return Err(bad(path, &field, "start or goal is outside the map".into()));
        }
        let planned = plan_on_grid(world, &blocked, s, g)
            .or_else(|| crate::path::plan_path(world, s, g, 0.0))
            .ok_or_else(|| bad(path, &field, "no path between start and goal".into()))?;
        tasks.push(Task {
            world_id: world.id,
            index: k as u32,
            start: s,
            goal: g,
            path: planned,
        });
    }
    Ok(tasks)
}
