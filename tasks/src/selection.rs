//! Selecting tasks of a task set (`--tasks` of `vb eval`, `vb-submit` and the Python SDK): `all`, world ids, task
//! ids ([`contracts::TaskId`]) and named splits, as `contracts::catalog` defines them.

use crate::{TaskSet, TasksError};
use contracts::catalog::WorldFacts;
use std::collections::BTreeMap;

pub use contracts::catalog::SPLITS;

impl TaskSet {
    /// Each world's factors and terrain group, by id (what task selection and the service's catalog read).
    pub fn world_facts(&self) -> BTreeMap<u32, WorldFacts> {
        self.manifest
            .worlds
            .iter()
            .map(|w| {
                let facts = WorldFacts {
                    level: w.level,
                    semantics: w.semantics,
                    density: w.density,
                    terrain: w.terrain,
                };
                (w.id, facts)
            })
            .collect()
    }
}

/// Selects `(world id, task index)` pairs from a task set ([`contracts::catalog::select`]).
pub fn select(set: &TaskSet, spec: &str) -> Result<Vec<(u32, u32)>, TasksError> {
    contracts::catalog::select(&set.world_facts(), spec)
        .map(|ids| ids.into_iter().map(|t| (t.world, t.index)).collect())
        .map_err(|e| TasksError::Param {
            field: "tasks".into(),
            message: e.0,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_and_overlapping_items_select_each_task_once() {
        let set = TaskSet::committed().unwrap();
        let all = select(&set, "all").unwrap();
        assert_eq!(all.len(), 10 * set.world_ids().len());
        assert_eq!(select(&set, "all,all").unwrap(), all);
        assert_eq!(select(&set, " all , low ,all").unwrap(), all);
        let one = select(&set, "w001-t3,w001-t3,1").unwrap();
        assert_eq!(one, select(&set, "1").unwrap());
        let e = select(&set, "all,banana").unwrap_err().to_string();
        assert!(e.contains("`banana` is not `all`"), "{e}");
    }
}
