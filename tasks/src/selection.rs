//! Selecting tasks of a task set (`--tasks` of `vb eval`, `vb-submit` and the Python SDK): `all`, world ids, task
//! ids ([`contracts::TaskId`]) and named splits.

use crate::{TaskSet, TasksError};
use contracts::TaskId;
use std::collections::BTreeSet;

/// Named splits of the task set for `--tasks`: every task of the worlds with one factor level. An item list is a
/// union (`low,dense` = the low worlds and the dense worlds); `+` intersects (`low+rigid` = the low rigid worlds).
pub const SPLITS: [&str; 9] = [
    "low",
    "medium",
    "high",
    "rigid",
    "deformable",
    "mixed",
    "sparse",
    "medium-density",
    "dense",
];

/// Whether a world with these factors belongs to a named split.
fn in_split(w: &crate::format::WorldEntry, split: &str) -> bool {
    match split {
        "medium-density" => w.density.as_str() == "medium",
        "sparse" | "dense" => w.density.as_str() == split,
        "rigid" | "deformable" | "mixed" => w.semantics.as_str() == split,
        _ => w.level.as_str() == split,
    }
}

/// Selects `(world id, task index)` pairs from a task set: the union of the comma-separated items, each task once,
/// in id order.
pub fn select(set: &TaskSet, spec: &str) -> Result<Vec<(u32, u32)>, TasksError> {
    let ids = set.world_ids();
    let all = || {
        ids.iter()
            .flat_map(|&w| (0..10).map(move |t| (w, t)))
            .collect::<Vec<_>>()
    };
    if spec.trim() == "all" {
        return Ok(all());
    }
    // A union: items may repeat or overlap (`all,all`, `low,w001-t0`); each task is selected once.
    let mut out = BTreeSet::new();
    for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        if item == "all" {
            out.extend(all());
            continue;
        }
        let bad = || {
            TasksError::Param {
            field: "tasks".into(),
            message: format!(
                "`{item}` is not `all`, a world id, a task id like w017-t3, a split ({}) or splits joined by `+` (low+rigid: both)",
                SPLITS.join(", ")
            ),
        }
        };
        let parts: Vec<&str> = item.split('+').map(str::trim).collect();
        if parts.iter().all(|p| SPLITS.contains(p)) {
            // `low+rigid`: the worlds in every one of the splits.
            for &w in &ids {
                let meta = set.world_meta(w)?;
                if parts.iter().all(|p| in_split(meta, p)) {
                    out.extend((0..10).map(|t| (w, t)));
                }
            }
        } else if item.starts_with('w') {
            let id: TaskId = item.parse().map_err(|_| bad())?;
            let (w, t) = (id.world, id.index);
            if !ids.contains(&w) || t >= 10 {
                return Err(TasksError::Param {
                    field: "tasks".into(),
                    message: format!("task `{item}` is not in the task set"),
                });
            }
            out.insert((w, t));
        } else {
            let w: u32 = item.parse().map_err(|_| bad())?;
            if !ids.contains(&w) {
                return Err(TasksError::Param {
                    field: "tasks".into(),
                    message: format!("world {w} is not in the task set"),
                });
            }
            out.extend((0..10).map(|t| (w, t)));
        }
    }
    if out.is_empty() {
        return Err(TasksError::Param {
            field: "tasks".into(),
            message: "no task selected".into(),
        });
    }
    Ok(out.into_iter().collect())
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
