//! `--tasks` accepts named splits (factor levels) besides world and task ids.

use eval::run::{select, SPLITS};
use tasks::TaskSet;

#[test]
fn named_splits_select_every_task_of_the_worlds_with_that_factor() {
    let set = TaskSet::committed().unwrap();
    let mut total = 0;
    for split in SPLITS {
        let sel = select(&set, split).unwrap();
        assert!(!sel.is_empty() && sel.len().is_multiple_of(10), "{split}");
        for (w, _) in &sel {
            let m = set.world_meta(*w).unwrap();
            let got = match split {
                "low" | "medium" | "high" => m.level.as_str().to_string(),
                "rigid" | "deformable" | "mixed" => m.semantics.as_str().to_string(),
                "medium-density" => format!("{}-density", m.density.as_str()),
                _ => m.density.as_str().to_string(),
            };
            assert_eq!(got, split, "world {w}");
        }
        total += sel.len();
    }
    // Each factor partitions the set.
    assert_eq!(total, 3 * select(&set, "all").unwrap().len());
    assert_ne!(
        select(&set, "medium").unwrap(),
        select(&set, "medium-density").unwrap()
    );
    // A list is a union, without duplicates.
    let low = select(&set, "low").unwrap();
    let union = select(&set, "low,dense,w001-t0").unwrap();
    assert!(union.len() >= low.len() && low.iter().all(|t| union.contains(t)));
    let mut dedup = union.clone();
    dedup.dedup();
    assert_eq!(dedup, union);
    let err = select(&set, "steep").unwrap_err().to_string();
    assert!(err.contains("medium-density"), "{err}");
}

#[test]
fn splits_joined_by_plus_intersect() {
    let set = TaskSet::committed().unwrap();
    let (low, rigid) = (select(&set, "low").unwrap(), select(&set, "rigid").unwrap());
    let both = select(&set, "low+rigid").unwrap();
    let expected: Vec<_> = low.iter().filter(|t| rigid.contains(t)).copied().collect();
    assert!(!both.is_empty() && both.len() < low.len());
    assert_eq!(both, expected);
    assert_eq!(select(&set, "rigid + low").unwrap(), both);
    let err = select(&set, "low+steep").unwrap_err().to_string();
    assert!(err.contains("joined by `+`"), "{err}");
}
