//! The balanced, density-matched design of the 100 worlds.
//!
//! Worlds come in *terrain groups*: the worlds of one group share their heightmap and their semantic patches and
//! differ only in obstacle density, and their obstacle layouts are nested (the sparse world's rocks and tree are
//! the first ones of the medium world's, which are the first ones of the dense world's). A density contrast inside
//! a group is therefore a pure obstacle effect, with terrain and surface held fixed; comparing densities across
//! different worlds mixes in the spread of terrain between worlds, which is larger than the effect of 10 against
//! 40 rocks for a planner that steers around them.
//!
//! - Groups 1..=33 are triples: worlds `3g - 2`, `3g - 1`, `3g` have density sparse, medium, dense.
//!   Groups 1..=27 run through the 9 (level, semantics) cells three times (level varies fastest); groups 28..=33
//!   add one more triple to the six cells with level != semantics (in `ALL` order), so every level and every
//!   semantics kind has 11 triples.
//! - Group 34 is world 100 alone (high, mixed, dense).
//!
//! Every level, semantics kind and density therefore appears in 33 or 34 worlds and every one of the 27
//! combinations in 3 or 4 worlds, so the breakdowns of the leaderboard stay balanced.

use sim_core::world::{ElevationLevel, ObstacleDensity, SemanticsKind};

/// Number of worlds in the benchmark.
pub const WORLDS: u32 = 100;
/// Tasks (start/goal pairs) per world.
pub const TASKS_PER_WORLD: u32 = 10;
/// Number of terrain groups (33 density triples and world 100 alone).
pub const TERRAIN_GROUPS: u32 = 34;
const TRIPLES: u32 = 33;
/// The six extra (level, semantics) cells of groups 28..=33, as indices into `ALL`.
const EXTRA_CELLS: [(usize, usize); 6] = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)];

/// The factors of one world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Factors {
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// Terrain group (1..=34): worlds of one group share heights and patches and have nested obstacles.
    pub terrain: u32,
}

/// Factors of world `id` (1-based, 1..=100).
pub fn factors(id: u32) -> Factors {
    let i = id.clamp(1, WORLDS) - 1;
    let g = i / 3;
    let (l, s, d) = if g < 27 {
        ((g % 3) as usize, ((g / 3) % 3) as usize, (i % 3) as usize)
    } else if g < TRIPLES {
        let (l, s) = EXTRA_CELLS[(g - 27) as usize];
        (l, s, (i % 3) as usize)
    } else {
        (2, 2, 2)
    };
    Factors {
        level: ElevationLevel::ALL[l],
        semantics: SemanticsKind::ALL[s],
        density: ObstacleDensity::ALL[d],
        terrain: g + 1,
    }
}

/// The worlds of terrain group `terrain`, sparsest first.
pub fn group_members(terrain: u32) -> Vec<u32> {
    (1..=WORLDS)
        .filter(|&id| factors(id).terrain == terrain)
        .collect()
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
            *combos.entry((f.level, f.semantics, f.density)).or_insert(0) += 1;
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
        assert!(combos.values().all(|c| (3..=4).contains(c)), "{combos:?}");
    }

    #[test]
    fn terrain_groups_are_density_triples_on_one_level_and_semantics() {
        let mut seen = 0;
        for g in 1..=TERRAIN_GROUPS {
            let members = group_members(g);
            seen += members.len();
            let f: Vec<Factors> = members.iter().map(|&id| factors(id)).collect();
            if g <= TRIPLES {
                assert_eq!(
                    f.iter().map(|f| f.density).collect::<Vec<_>>(),
                    ObstacleDensity::ALL,
                    "group {g}"
                );
            } else {
                assert_eq!(members, vec![100]);
            }
            assert!(
                f.iter()
                    .all(|x| x.level == f[0].level && x.semantics == f[0].semantics),
                "group {g}"
            );
        }
        assert_eq!(seen, WORLDS as usize);
    }
}
