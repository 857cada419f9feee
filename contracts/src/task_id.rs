//! A task's id, `wNNN-tK`: world `NNN` (at least three digits) and its `K`th start/goal pair. One formatter
//! ([`std::fmt::Display`]) and one parser ([`std::str::FromStr`]) for every crate.

use serde::{Deserialize, Serialize};

/// Task `index` of world `world`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct TaskId {
    pub world: u32,
    pub index: u32,
}

/// Text that is not a task id.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("`{0}` is not a task id (wNNN-tK, e.g. w001-t0)")]
pub struct TaskIdError(pub String);

impl TaskId {
    pub fn new(world: u32, index: u32) -> TaskId {
        TaskId { world, index }
    }
}

impl std::fmt::Display for TaskId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "w{:03}-t{}", self.world, self.index)
    }
}

impl std::str::FromStr for TaskId {
    type Err = TaskIdError;

    fn from_str(s: &str) -> Result<TaskId, TaskIdError> {
        let bad = || TaskIdError(s.to_string());
        let (w, t) = s
            .strip_prefix('w')
            .and_then(|r| r.split_once("-t"))
            .ok_or_else(bad)?;
        let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
        if !digits(w) || !digits(t) || w.len() < 3 {
            return Err(bad());
        }
        let id = TaskId {
            world: w.parse().map_err(|_| bad())?,
            index: t.parse().map_err(|_| bad())?,
        };
        // One spelling per task: `w001-t0`, not `w0001-t00`.
        if id.to_string() != s {
            return Err(bad());
        }
        Ok(id)
    }
}

impl Serialize for TaskId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for TaskId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_spelling_formatted_and_parsed() {
        assert_eq!(TaskId::new(1, 0).to_string(), "w001-t0");
        assert_eq!(TaskId::new(1234, 12).to_string(), "w1234-t12");
        for s in ["w001-t0", "w100-t9", "w1234-t12"] {
            assert_eq!(s.parse::<TaskId>().map(|t| t.to_string()).as_deref(), Ok(s));
        }
        for bad in [
            "", "w1-t0", "w001t0", "w001-t", "x001-t0", "w001-t0 ", "w0001-t0", "w001-t00",
            "w-01-t0",
        ] {
            assert!(bad.parse::<TaskId>().is_err(), "{bad:?} parsed");
        }
        assert_eq!(
            serde_json::from_str::<TaskId>("\"w040-t2\"").ok(),
            Some(TaskId::new(40, 2))
        );
    }
}
