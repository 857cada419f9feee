//! The balanced design of the 100 worlds.
//!
//! Worlds 1..=81 run through the 27 (level, semantics, density) combinations three times (level varies fastest,
//! then semantics, then density). Worlds 82..=100 take 19 more combinations chosen so that every level, every
//! semantics kind and every density appears in 33 or 34 worlds overall. Every combination therefore appears in at
//! least 3 worlds, and the breakdowns of the leaderboard are balanced.

use sim_core::world::{ElevationLevel, ObstacleDensity, SemanticsKind};

/// Number of worlds in the benchmark.
pub const WORLDS: u32 = 100;
/// Tasks (start/goal pairs) per world.
pub const TASKS_PER_WORLD: u32 = 10;

/// The factors of one world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Factors {
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
}

/// Factors of world `id` (1-based, 1..=100).
pub fn factors(id: u32) -> Factors {
    let i = (id.max(1) - 1) as usize;
    let (l, s, d) = if i < 81 {
        (i % 3, (i / 3) % 3, (i / 9) % 3)
    } else {
        let j = i - 81;
        (j % 3, (j / 3) % 3, (j / 9 + j) % 3)
    };
    Factors {
        level: ElevationLevel::ALL[l],
        semantics: SemanticsKind::ALL[s],
        density: ObstacleDensity::ALL[d],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn every_factor_level_in_33_or_34_worlds_and_every_combination_at_least_3() {
        let all: Vec<Factors> = (1..=WORLDS).map(factors).collect();
        let mut levels = BTreeMap::new();
        let mut sems = BTreeMap::new();
        let mut dens = BTreeMap::new();
        let mut combos = BTreeMap::new();
        for f in &all {
            *levels.entry(f.level).or_insert(0) += 1;
            *sems.entry(f.semantics).or_insert(0) += 1;
            *dens.entry(f.density).or_insert(0) += 1;
            *combos.entry(*f).or_insert(0) += 1;
        }
        for counts in [
            levels.values().collect::<Vec<_>>(),
            sems.values().collect(),
            dens.values().collect(),
        ] {
            assert_eq!(counts.len(), 3);
            for c in counts {
                assert!(*c == 33 || *c == 34, "count {c}");
            }
        }
        assert_eq!(combos.len(), 27);
        assert!(combos.values().all(|c| *c >= 3));
    }
}
