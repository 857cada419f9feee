//! The generation pipeline: from a master seed and a height source to 100 worlds with 10 tasks each.
//!
//! For world `id` the generator derives its own seed (`world_seed`), takes its factors from [`crate::design`],
//! asks the height source for a heightmap of the world's elevation level, samples semantic patches, places the ten
//! start/goal pairs (diametrically opposite points of a 60 m circle at 36 degree steps, the first start at angle 0),
//! places obstacles and plans the ten global paths. If some task has no path, the obstacles are resampled (up to
//! 100 times; every one of the 1000 tasks must have a path). Everything is a pure function of the seed and the
//! height source, so the set is reproducible byte for byte.

use crate::design::{factors, TASKS_PER_WORLD};
use crate::format::WorldRecord;
use crate::path::{occupancy, plan_on_grid, DEFAULT_INFLATION};
use crate::{obstacles, semantics, TasksError};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sim_core::world::{ElevationLevel, Heightmap, Task, World, MAP_PX};

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

/// Seed of world `id` derived from the master seed (SplitMix64 of the pair).
pub fn world_seed(master: u64, id: u32) -> u64 {
    let mut z = master ^ (id as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
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

/// Builds the rest of a world around a heightmap: patches, obstacles, tasks and paths.
pub fn build_world(id: u32, seed: u64, heightmap: Heightmap) -> Result<WorldRecord, TasksError> {
    if heightmap.nx != MAP_PX || heightmap.ny != MAP_PX {
        return Err(TasksError::Generation {
            world: id,
            message: format!(
                "heightmap is {} x {}, expected {MAP_PX} x {MAP_PX}",
                heightmap.nx, heightmap.ny
            ),
        });
    }
    let f = factors(id);
    // The height source used `seed`; the layout draws from its own stream.
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_add(1));
    let patches = semantics::generate_patches(f.semantics, &mut rng);
    let pairs = start_goal_pairs();
    let keep_clear: Vec<[f64; 2]> = pairs.iter().flat_map(|(s, g)| [*s, *g]).collect();
    let mut world = World {
        id,
        scale: 1.0,
        level: f.level,
        semantics: f.semantics,
        density: f.density,
        heightmap,
        patches,
        obstacles: Vec::new(),
    };
    for _ in 0..MAX_LAYOUT_ATTEMPTS {
        let Some(obs) = obstacles::place(f.density, &world.heightmap, &keep_clear, &mut rng) else {
            continue;
        };
        world.obstacles = obs;
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
        if let Some(tasks) = tasks {
            return Ok(WorldRecord { world, tasks });
        }
    }
    Err(TasksError::Generation {
        world: id,
        message: format!(
            "no obstacle layout with a path for every task in {MAX_LAYOUT_ATTEMPTS} attempts"
        ),
    })
}

/// Generates worlds `ids` from the master seed and a height source.
pub fn generate(
    master_seed: u64,
    ids: &[u32],
    source: &dyn HeightSource,
) -> Result<Vec<WorldRecord>, TasksError> {
    ids.iter()
        .map(|&id| {
            let seed = world_seed(master_seed, id);
            let heights = source.heightmap(seed, factors(id).level)?;
            build_world(id, seed, heights)
        })
        .collect()
}
