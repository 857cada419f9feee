//! The environments' observation: the vehicle's state and the goal as vectors, and heading-aligned map crops
//! (sim-core's `observe`, the same crops the planner protocol sends), written into per-environment buffers.

use sim_core::observe::{
    goal_vector, obstacle_crop, relative_elevation_crop, semantics_crop, state_vector, CropSpec,
};
use sim_core::planner::VehicleState;
use sim_core::world::World;

/// Names of the `state` and `goal` vectors' entries (sim-core's, shared with the datasets).
pub use sim_core::observe::{GOAL_FIELDS, STATE_FIELDS};

/// One environment's observation.
#[derive(Clone, Debug)]
pub struct ObsBuf {
    pub state: [f64; STATE_FIELDS.len()],
    pub goal: [f64; GOAL_FIELDS.len()],
    /// Elevation relative to the chassis reference point's height, m (`size * size`, row 0 ahead, column 0 left).
    pub elevation: Vec<f32>,
    pub semantics: Vec<u8>,
    pub obstacles: Vec<u8>,
    /// Under a perception profile that degrades the maps: 1 where the crop's believed height is known; the
    /// elevation is 0 where it is not (read it only where `known` says so). Empty under ground truth.
    pub known: Vec<u8>,
}

impl ObsBuf {
    pub fn new(crop: Option<&CropSpec>) -> ObsBuf {
        let n = crop.map_or(0, |c| c.size * c.size);
        ObsBuf {
            state: [0.0; STATE_FIELDS.len()],
            goal: [0.0; GOAL_FIELDS.len()],
            elevation: vec![0.0; n],
            semantics: vec![0; n],
            obstacles: vec![0; n],
            known: Vec::new(),
        }
    }

    /// Writes the observation of `s` on `world` with the goal at `goal`; `believed`: `world` is the perception
    /// layer's belief (unknown heights `NaN`), and the crop gets its known mask.
    pub fn write(
        &mut self,
        s: &VehicleState,
        world: &World,
        goal: [f64; 2],
        crop: Option<&CropSpec>,
        believed: bool,
    ) {
        // The same functions the datasets record with (sim-core's `observe`), so both see identical values.
        self.state = state_vector(s);
        self.goal = goal_vector(s, goal);
        if let Some(spec) = crop {
            relative_elevation_crop(world, s, spec, &mut self.elevation);
            semantics_crop(world, s, spec, &mut self.semantics);
            obstacle_crop(world, s, spec, &mut self.obstacles);
            if believed {
                self.known.clear();
                for z in &mut self.elevation {
                    self.known.push(u8::from(z.is_finite()));
                    if !z.is_finite() {
                        *z = 0.0;
                    }
                }
            }
        }
    }

    pub fn copy_from(&mut self, o: &ObsBuf) {
        self.state = o.state;
        self.goal = o.goal;
        self.elevation.copy_from_slice(&o.elevation);
        self.semantics.copy_from_slice(&o.semantics);
        self.obstacles.copy_from_slice(&o.obstacles);
        self.known.clone_from(&o.known);
    }
}
