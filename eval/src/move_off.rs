//! The move-off check ([`sim_core::move_off`]) from every start of a task set, the tasks in parallel: how many
//! starts a vehicle cannot get 5 m away from at full throttle towards the goal (`vb sim characterize --task-dir`).

use crate::EvalError;
use rayon::prelude::*;
use sim_core::vehicle::VehicleSpec;
use std::sync::Arc;
use tasks::TaskSet;

/// The check's result over a task set.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MoveOff {
    /// Starts checked (every task of the set).
    pub starts: usize,
    /// Ids of the tasks whose start the vehicle cannot move off from, in task order.
    pub stuck: Vec<String>,
}

impl MoveOff {
    /// Share of the starts the vehicle cannot move off from, in [0, 1] (0 for an empty set).
    pub fn stuck_share(&self) -> f64 {
        self.stuck.len() as f64 / self.starts.max(1) as f64
    }
}

/// Runs the check from every start of `set` with `spec` at physics step `dt` (default: the vehicle's).
pub fn move_off(set: &TaskSet, spec: &VehicleSpec, dt: Option<f64>) -> Result<MoveOff, EvalError> {
    let mut jobs = Vec::new();
    for id in set.world_ids() {
        let world = Arc::new(set.world(id, spec.scale)?);
        for task in set.tasks(id, spec.scale)? {
            jobs.push((world.clone(), task));
        }
    }
    let stuck = jobs
        .par_iter()
        .filter(|(world, task)| !sim_core::move_off::moves_off(world, task, spec, dt))
        .map(|(_, task)| task.id())
        .collect();
    Ok(MoveOff {
        starts: jobs.len(),
        stuck,
    })
}
