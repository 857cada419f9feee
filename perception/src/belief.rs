//! The world as the planner believes it, in the simulator's own `World` type, so the map crops of
//! `sim_core::observe` read it as they read the truth: the heights of the online map (`NaN` where a cell is
//! unknown, so a crop's sample next to one reads `NaN`: unknown, never flat ground), or the true heights when the map
//! is given whole; each patch as classified, with its class's nominal surface; the obstacles known so far.

use crate::map::OnlineMap;
use sim_core::world::{Obstacle, Patch, World};
use std::sync::Arc;

/// One episode's believed world, shared with the planner's observations (an update copies it only while a planner
/// still holds the previous one); [`Belief::revision`] counts its updates.
#[derive(Clone, Debug)]
pub struct Belief {
    world: Arc<World>,
    revision: u64,
}

impl Belief {
    /// The belief before the first scan: every cell unknown when the map is built online.
    pub fn new(truth: &World, patches: Vec<Patch>, online: bool) -> Belief {
        let mut world = truth.clone();
        world.patches = patches;
        world.obstacles.clear();
        if online {
            world.heightmap.heights.fill(f32::NAN);
        }
        Belief {
            world: Arc::new(world),
            revision: 0,
        }
    }

    /// Takes a scan's result: the fused heights (when built online) and the obstacles known now.
    pub fn update(&mut self, map: Option<&OnlineMap>, obstacles: &[Obstacle]) {
        let world = Arc::make_mut(&mut self.world);
        if let Some(m) = map {
            world.heightmap.heights.copy_from_slice(&m.height);
        }
        world.obstacles.clear();
        world.obstacles.extend_from_slice(obstacles);
        self.revision += 1;
    }

    pub fn world(&self) -> &World {
        &self.world
    }

    /// The believed world as an observation carries it.
    pub fn shared(&self) -> Arc<World> {
        self.world.clone()
    }

    pub fn revision(&self) -> u64 {
        self.revision
    }

    /// Whether the believed height at (x, y) is known (every sample its bilinear height reads has been seen).
    pub fn is_known(&self, x: f64, y: f64) -> bool {
        self.world.heightmap.height_bilinear(x, y).is_finite()
    }
}
