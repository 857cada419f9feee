//! The generation pipeline: from a master seed and a height source to 100 worlds with 10 tasks each.
//!
//! Worlds are made per terrain group ([`crate::design`]): for group `g` the generator derives its seed
//! (`terrain_seed(master, g)`), asks the height source for a heightmap of the group's elevation level, samples the
//! semantic patches, places the ten start/goal pairs (diametrically opposite points of a 60 m circle at 36 degree
//! steps, the first start at angle 0), places one obstacle layout at the group's highest density, gives every
//! member world its nested share of it and plans the ten global paths of every member. If some task has no path,
//! the layout is resampled (up to 100 times; every one of the 1000 tasks must have a path). Everything is a pure
//! function of the seed and the height source, so the set is reproducible byte for byte.

use crate::design::{factors, group_members, TASKS_PER_WORLD, TERRAIN_GROUPS};
use crate::format::WorldRecord;
use crate::path::{occupancy, plan_on_grid, DEFAULT_INFLATION};
use crate::{obstacles, semantics, TasksError};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sim_core::world::{ElevationLevel, Heightmap, SemanticsKind, Task, World, MAP_PX};
use std::collections::btree_map::{BTreeMap, Entry};

/// The committed master seed of the benchmark's task set.
pub const DEFAULT_SEED: u64 = 20_250_602;
/// Radius of the start/goal circle at full scale, m.
pub const TASK_RADIUS: f64 = 60.0;
const MAX_LAYOUT_ATTEMPTS: usize = 100;

/// Where the heights of a generated world come from.
pub trait HeightSource {
    /// Identifies the source in the manifest (e.g. `swae:<weights hash>`).
    fn name(&self) -> String;
    /// A 129 x 129 heightmap at 1 m for an elevation level, from a seed.
    fn heightmap(&self, seed: u64, level: ElevationLevel) -> Result<Heightmap, TasksError>;
}

/// Seed of terrain group `terrain` derived from the master seed (SplitMix64 of the pair).
pub fn terrain_seed(master: u64, terrain: u32) -> u64 {
    let mut z = master ^ (terrain as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Checks that a set made from master seed `seed` is held out from the benchmark's set: none of its terrain
/// groups has the seed of one of the benchmark's groups ([`DEFAULT_SEED`]), so it shares no heightmap, patches,
/// obstacles or tasks with it (every one of those is drawn from the group's seed). Distinct master seeds almost
/// always give disjoint group seeds; this refuses the few that do not (training sets for a hidden test split).
pub fn check_held_out(seed: u64) -> Result<(), TasksError> {
    let benchmark: Vec<u64> = (1..=TERRAIN_GROUPS)
        .map(|g| terrain_seed(DEFAULT_SEED, g))
        .collect();
    for g in 1..=TERRAIN_GROUPS {
        let s = terrain_seed(seed, g);
        if let Some(b) = benchmark.iter().position(|&b| b == s) {
            return Err(TasksError::Param {
                field: "seed".into(),
                message: format!(
                    "seed {seed}'s terrain group {g} would repeat terrain group {} of the benchmark's set (seed \
                     {DEFAULT_SEED}): choose another seed",
                    b + 1
                ),
            });
        }
    }
    Ok(())
}

/// The ten start/goal pairs at full scale.
pub fn start_goal_pairs() -> Vec<([f64; 2], [f64; 2])> {
    (0..TASKS_PER_WORLD)
        .map(|k| {
            let a = (36.0 * k as f64).to_radians();
            let (s, c) = a.sin_cos();
            let round = |v: f64| (v * 1e6).round() / 1e6 + 0.0;
            (
                [round(TASK_RADIUS * c), round(TASK_RADIUS * s)],
                [round(-TASK_RADIUS * c), round(-TASK_RADIUS * s)],
            )
        })
        .collect()
}

/// Builds the worlds of terrain group `terrain` around its heightmap: the shared patches, one obstacle layout for
/// the group's densest member (the others take its first rocks and trees, [`obstacles::nested`]), tasks and paths.
/// The layout is resampled until every task of every member has a path.
///
/// With `surface = Some(kind)` the group's patches are replaced by patches of `kind` drawn from a separate stream
/// of the group's seed, after the design's patches were drawn and before the layout: heights, obstacles, tasks
/// and paths stay exactly those of the design's set (paths ignore the surface), only the ground changes. That makes
/// a *surface counterfactual* of the set, for paired semantics contrasts ([`generate_with_surface`]).
pub fn build_group(
    terrain: u32,
    seed: u64,
    heightmap: Heightmap,
    surface: Option<SemanticsKind>,
) -> Result<Vec<WorldRecord>, TasksError> {
    let members = group_members(terrain);
    let first = *members.first().ok_or_else(|| TasksError::Generation {
        world: 0,
        message: format!("terrain group {terrain} has no worlds"),
    })?;
    if heightmap.nx != MAP_PX || heightmap.ny != MAP_PX {
        return Err(TasksError::Generation {
            world: first,
            message: format!(
                "heightmap is {} x {}, expected {MAP_PX} x {MAP_PX}",
                heightmap.nx, heightmap.ny
            ),
        });
    }
    let f = factors(first);
    let densest = members
        .iter()
        .map(|&id| factors(id).density)
        .max()
        .unwrap_or(f.density);
    // The height source used `seed`; the layout draws from its own stream.
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1));
    // The design's patches are drawn even for a counterfactual, so the layout below draws the same obstacles.
    let design_patches = semantics::generate_patches(f.semantics, &mut rng);
    let (kind, patches) = match surface {
        None => (f.semantics, design_patches),
        Some(k) => {
            let mut surface_rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(2));
            (k, semantics::generate_patches(k, &mut surface_rng))
        }
    };
    let pairs = start_goal_pairs();
    let keep_clear: Vec<[f64; 2]> = pairs.iter().flat_map(|(s, g)| [*s, *g]).collect();
    for _ in 0..MAX_LAYOUT_ATTEMPTS {
        let Some(layout) = obstacles::place(densest, &heightmap, &keep_clear, &mut rng) else {
            continue;
        };
        let records: Option<Vec<WorldRecord>> = members
            .iter()
            .map(|&id| {
                let density = factors(id).density;
                let world = World {
                    id,
                    scale: 1.0,
                    level: f.level,
                    semantics: kind,
                    density,
                    heightmap: heightmap.clone(),
                    patches: patches.clone(),
                    obstacles: obstacles::nested(&layout, density),
                };
                let blocked = occupancy(&world, DEFAULT_INFLATION);
                let tasks: Option<Vec<Task>> = pairs
                    .iter()
                    .enumerate()
                    .map(|(k, (s, g))| {
                        plan_on_grid(&world, &blocked, *s, *g).map(|path| Task {
                            world_id: id,
                            index: k as u32,
                            start: *s,
                            goal: *g,
                            path,
                        })
                    })
                    .collect();
                tasks.map(|tasks| WorldRecord {
                    world,
                    tasks,
                    terrain: Some(terrain),
                })
            })
            .collect();
        if let Some(records) = records {
            return Ok(records);
        }
    }
    Err(TasksError::Generation {
        world: first,
        message: format!(
            "terrain group {terrain}: no obstacle layout with a path for every task in {MAX_LAYOUT_ATTEMPTS} attempts"
        ),
    })
}

/// Generates worlds `ids` from the master seed and a height source. Each terrain group is built once, from the
/// seed of the group ([`terrain_seed`] of the master seed and the group number), whichever of its worlds are asked
/// for, so a world is the same whether it is generated alone or with the whole set.
pub fn generate(
    master_seed: u64,
    ids: &[u32],
    source: &dyn HeightSource,
) -> Result<Vec<WorldRecord>, TasksError> {
    generate_with_surface(master_seed, ids, source, None)
}

/// [`generate`], or with `surface = Some(kind)` its surface counterfactual: every world keeps its heights,
/// obstacles, tasks and paths and gets patches of semantics kind `kind` instead (see [`build_group`]). Evaluating
/// one planner on the counterfactuals of the three kinds pairs every task with itself on rigid, mixed and
/// deformable ground, so a semantics contrast carries no terrain or obstacle spread.
pub fn generate_with_surface(
    master_seed: u64,
    ids: &[u32],
    source: &dyn HeightSource,
    surface: Option<SemanticsKind>,
) -> Result<Vec<WorldRecord>, TasksError> {
    let mut groups: BTreeMap<u32, Vec<WorldRecord>> = BTreeMap::new();
    ids.iter()
        .map(|&id| {
            let f = factors(id);
            if let Entry::Vacant(slot) = groups.entry(f.terrain) {
                let seed = terrain_seed(master_seed, f.terrain);
                let heights = source.heightmap(seed, f.level)?;
                slot.insert(build_group(f.terrain, seed, heights, surface)?);
            }
            groups[&f.terrain]
                .iter()
                .find(|r| r.world.id == id)
                .cloned()
                .ok_or(TasksError::UnknownWorld(id))
        })
        .collect()
}
