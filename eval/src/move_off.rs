//! The move-off check ([`sim_core::move_off`]) from every start of a task set, the tasks in parallel: how many
//! starts a vehicle cannot get 5 m away from at full throttle towards the goal (`vb sim characterize --task-dir`);
//! and start by start beside a reference's (the Chrono harness's `move-off`: issue 59, item 4).

use crate::EvalError;
use contracts::TaskId;
use rayon::prelude::*;
use sim_core::move_off::MOVE_OFF_DISTANCE;
use sim_core::vehicle::VehicleSpec;
use std::sync::Arc;
use tasks::TaskSet;

/// The check's result over a task set: how far the vehicle got from every start, in task order. Serialises as
/// `{"starts": N, "stuck": [ids], "tasks": [{"task", "distance"}]}` (the first two derived from the last).
#[derive(Clone, Debug, PartialEq)]
pub struct MoveOff {
    pub tasks: Vec<StartDistance>,
}

/// How far the vehicle got from one task's start in the check's 20 s, m at full scale.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StartDistance {
    pub task: TaskId,
    pub distance: f64,
}

impl StartDistance {
    /// Whether the vehicle moved off (at least [`MOVE_OFF_DISTANCE`]).
    pub fn moved(&self) -> bool {
        self.distance >= MOVE_OFF_DISTANCE
    }
}

impl MoveOff {
    /// Starts checked (every task of the set).
    pub fn starts(&self) -> usize {
        self.tasks.len()
    }
    /// Ids of the tasks whose start the vehicle cannot move off from, in task order.
    pub fn stuck(&self) -> Vec<TaskId> {
        self.tasks
            .iter()
            .filter(|t| !t.moved())
            .map(|t| t.task)
            .collect()
    }
    /// Share of the starts the vehicle cannot move off from, in [0, 1] (0 for an empty set).
    pub fn stuck_share(&self) -> f64 {
        self.stuck().len() as f64 / self.starts().max(1) as f64
    }
}

impl serde::Serialize for MoveOff {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        let mut m = s.serialize_struct("MoveOff", 3)?;
        m.serialize_field("starts", &self.starts())?;
        m.serialize_field("stuck", &self.stuck())?;
        m.serialize_field("tasks", &self.tasks)?;
        m.end()
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
    let tasks: Vec<StartDistance> = jobs
        .par_iter()
        .map(|(world, task)| StartDistance {
            task: TaskId::new(task.world_id, task.index),
            distance: sim_core::move_off::move_off_distance(world, task, spec, dt) / spec.scale,
        })
        .collect();
    Ok(MoveOff { tasks })
}

/// One start, ours beside the reference's.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct StartPair {
    pub task: TaskId,
    /// Distance from the start after the check's 20 s, m at full scale.
    pub ours: f64,
    pub reference: f64,
}

impl StartPair {
    pub fn ours_moved(&self) -> bool {
        self.ours >= MOVE_OFF_DISTANCE
    }
    pub fn reference_moved(&self) -> bool {
        self.reference >= MOVE_OFF_DISTANCE
    }
}

/// The move-off check start by start, ours beside a reference's, and how often they agree.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Agreement {
    /// The starts both checked, in our task order.
    pub starts: Vec<StartPair>,
    pub both_moved: usize,
    pub both_stranded: usize,
    /// Stranded in ours, moved in the reference.
    pub only_ours_stranded: usize,
    /// Moved in ours, stranded in the reference.
    pub only_reference_stranded: usize,
    /// Our starts the reference does not list.
    pub not_in_reference: Vec<TaskId>,
}

/// Pairs our check with `reference` (task and distance, as [`crate::reference::move_off`] reads it).
pub fn agreement(ours: &MoveOff, reference: &[StartDistance]) -> Agreement {
    let mut a = Agreement {
        starts: Vec::new(),
        both_moved: 0,
        both_stranded: 0,
        only_ours_stranded: 0,
        only_reference_stranded: 0,
        not_in_reference: Vec::new(),
    };
    for t in &ours.tasks {
        let Some(r) = reference.iter().find(|r| r.task == t.task) else {
            a.not_in_reference.push(t.task);
            continue;
        };
        let pair = StartPair {
            task: t.task,
            ours: t.distance,
            reference: r.distance,
        };
        match (pair.ours_moved(), pair.reference_moved()) {
            (true, true) => a.both_moved += 1,
            (false, false) => a.both_stranded += 1,
            (false, true) => a.only_ours_stranded += 1,
            (true, false) => a.only_reference_stranded += 1,
        }
        a.starts.push(pair);
    }
    a
}

/// The agreement as a table (one row a start), then its counts.
pub fn agreement_table(a: &Agreement) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "{:<9} {:>9} {:>11}  {:<8} {:<8}\n",
        "task", "ours m", "reference m", "ours", "reference"
    );
    let word = |moved: bool| if moved { "moved" } else { "STRANDED" };
    for p in &a.starts {
        let _ = writeln!(
            s,
            "{:<9} {:>9.1} {:>11.1}  {:<8} {:<8}",
            p.task.to_string(),
            p.ours,
            p.reference,
            word(p.ours_moved()),
            word(p.reference_moved())
        );
    }
    let _ = writeln!(
        s,
        "of {} starts: both moved {}, both stranded {}, stranded only in ours {}, stranded only in the reference {}{}",
        a.starts.len(),
        a.both_moved,
        a.both_stranded,
        a.only_ours_stranded,
        a.only_reference_stranded,
        if a.not_in_reference.is_empty() {
            String::new()
        } else {
            format!("; {} not in the reference", a.not_in_reference.len())
        }
    );
    s
}
