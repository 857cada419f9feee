//! The believed maps a planner outside the process holds (a gRPC planner, a Python one), kept in step with the
//! layer's belief: after each scan the rectangle of the grid whose heights or obstacles changed goes to the planner
//! as one [`MapPatch`] (the sensor's reach, not the whole map), so the planner keeps the map the layer has built.

use sim_core::world::World;
use std::sync::Arc;

/// A rectangle of the believed maps, `nx` x `ny` samples from sample `(x0, y0)`, row-major: heights (`NaN` where
/// unseen) and occupancy (1 = a known obstacle).
#[derive(Clone, Debug, PartialEq)]
pub struct MapPatch {
    pub x0: usize,
    pub y0: usize,
    pub nx: usize,
    pub ny: usize,
    pub heights: Vec<f32>,
    pub obstacles: Vec<u8>,
}

/// What the planner was last sent of the believed world.
pub struct MapSync {
    /// The belief the last update came from (a new belief is a new `Arc`: the layer copies it on update while an
    /// observation holds the previous one).
    last: Option<Arc<World>>,
    nx: usize,
    ny: usize,
    /// Heights the planner holds (`NaN` unknown), row-major.
    heights: Vec<f32>,
    /// Occupancy the planner holds.
    obstacles: Vec<u8>,
}

impl MapSync {
    /// The planner's maps as `EpisodeStart` gave them: the belief at the start.
    pub fn new(start: &World) -> MapSync {
        let h = &start.heightmap;
        MapSync {
            last: None,
            nx: h.nx,
            ny: h.ny,
            heights: h.heights.clone(),
            obstacles: sim_core::observe::occupancy_grid(start),
        }
    }

    /// The patch that brings the planner's maps to `belief`, `None` when nothing changed.
    pub fn update(&mut self, belief: &Arc<World>) -> Option<MapPatch> {
        if self.last.as_ref().is_some_and(|l| Arc::ptr_eq(l, belief)) {
            return None;
        }
        self.last = Some(belief.clone());
        let h = &belief.heightmap;
        if (h.nx, h.ny) != (self.nx, self.ny) {
            // A belief is always the world's own grid; refuse nothing, send nothing that could not be placed.
            return None;
        }
        let obstacles = sim_core::observe::occupancy_grid(belief);
        let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
        for iy in 0..self.ny {
            for ix in 0..self.nx {
                let k = iy * self.nx + ix;
                if h.heights[k].to_bits() != self.heights[k].to_bits()
                    || obstacles[k] != self.obstacles[k]
                {
                    x0 = x0.min(ix);
                    y0 = y0.min(iy);
                    x1 = x1.max(ix);
                    y1 = y1.max(iy);
                }
            }
        }
        self.heights.copy_from_slice(&h.heights);
        self.obstacles = obstacles;
        if x0 == usize::MAX {
            return None;
        }
        let (w, rows) = (x1 - x0 + 1, y1 - y0 + 1);
        let mut elevation = Vec::with_capacity(w * rows);
        let mut occupied = Vec::with_capacity(w * rows);
        for iy in y0..=y1 {
            let row = iy * self.nx + x0..iy * self.nx + x0 + w;
            elevation.extend_from_slice(&self.heights[row.clone()]);
            occupied.extend_from_slice(&self.obstacles[row]);
        }
        Some(MapPatch {
            x0,
            y0,
            nx: w,
            ny: rows,
            heights: elevation,
            obstacles: occupied,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use sim_core::world::{Heightmap, Semantic, Surface};

    fn world() -> World {
        World::uniform(
            Heightmap::from_fn(1.0, |x, _| x),
            Semantic::Dirt,
            Surface::Rigid { friction: 0.6 },
        )
    }

    /// Pastes a patch into row-major maps, as a planner does.
    fn paste(u: &MapPatch, nx: usize, heights: &mut [f32]) {
        for r in 0..u.ny {
            for c in 0..u.nx {
                heights[(u.y0 + r) * nx + u.x0 + c] = u.heights[r * u.nx + c];
            }
        }
    }

    #[test]
    fn an_update_covers_exactly_what_changed_and_pasting_it_gives_the_belief() {
        let truth = world();
        let mut start = truth.clone();
        start.heightmap.heights.fill(f32::NAN);
        let nx = start.heightmap.nx;
        let mut sync = MapSync::new(&start);
        let mut planner_heights = start.heightmap.heights.clone();
        // Nothing seen yet: no update.
        let same = Arc::new(start.clone());
        assert!(sync.update(&same).is_none());
        assert!(sync.update(&same).is_none(), "the same belief again");
        // A 3 x 2 patch of cells becomes known.
        let mut seen = start.clone();
        for (ix, iy) in [(10, 20), (12, 20), (11, 21)] {
            let k = iy * nx + ix;
            seen.heightmap.heights[k] = truth.heightmap.heights[k];
        }
        let u = sync.update(&Arc::new(seen.clone())).expect("an update");
        assert_eq!((u.x0, u.y0, u.nx, u.ny), (10, 20, 3, 2));
        let known: Vec<bool> = u.heights.iter().map(|z| z.is_finite()).collect();
        assert_eq!(known, [true, false, true, false, true, false]);
        paste(&u, nx, &mut planner_heights);
        let bits = |v: &[f32]| v.iter().map(|z| z.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&planner_heights), bits(&seen.heightmap.heights));
        // An obstacle's footprint alone is an update too.
        let mut with_rock = seen.clone();
        with_rock.obstacles.push(sim_core::world::Obstacle {
            kind: sim_core::world::ObstacleKind::Rock,
            x: 0.0,
            y: 0.0,
            z: 0.0,
            yaw: 0.0,
            half_extents: [1.0, 1.0, 0.5],
        });
        let u = sync.update(&Arc::new(with_rock)).expect("the rock");
        assert!(
            u.obstacles.iter().all(|&o| o == 1),
            "the rectangle is the footprint"
        );
        assert!(u.nx >= 2 && u.nx < 10);
    }
}
