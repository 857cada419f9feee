//! Semantics: the class the planner is told each patch has, drawn once per episode from the confusion matrix's row
//! of its true class (a classifier's map is wrong in the same place all episode), and the surface it is told: the
//! class's nominal friction (the release's mean for a rigid class) or its soil preset, never the patch's own sample.

use crate::profile::SemanticsNoise;
use crate::rng::uniform;
use rand_chacha::ChaCha8Rng;
use sim_core::world::{Patch, Semantic, Surface, World};

/// `confusion[true][seen]` for the ten classes in the release's order.
pub type Confusion = [[f64; 10]; 10];

/// The profile's confusion matrix (`error_rate` spread uniformly over the nine other classes, or its own matrix).
pub fn confusion(cfg: &SemanticsNoise) -> Confusion {
    let mut m = [[0.0; 10]; 10];
    match &cfg.confusion {
        Some(rows) => {
            for (i, row) in rows.iter().enumerate().take(10) {
                for (j, p) in row.iter().enumerate().take(10) {
                    m[i][j] = *p;
                }
            }
        }
        None => {
            for (i, row) in m.iter_mut().enumerate() {
                for (j, p) in row.iter_mut().enumerate() {
                    *p = if i == j {
                        1.0 - cfg.error_rate
                    } else {
                        cfg.error_rate / 9.0
                    };
                }
            }
        }
    }
    m
}

/// One draw from row `row` of a confusion matrix.
pub fn draw(row: &[f64; 10], rng: &mut ChaCha8Rng) -> Semantic {
    let u = uniform(rng);
    let mut acc = 0.0;
    for (j, p) in row.iter().enumerate() {
        acc += p;
        if u < acc {
            return Semantic::ALL[j];
        }
    }
    // Rounding left the sum a hair under 1: the last class with any probability.
    let last = row.iter().rposition(|p| *p > 0.0).unwrap_or(9);
    Semantic::ALL[last]
}

/// What the planner is told a class's ground is.
pub fn nominal_surface(class: Semantic) -> Surface {
    match (class.friction_distribution(), class.soil()) {
        (Some((mean, _)), _) => Surface::Rigid { friction: mean },
        (None, Some(soil)) => Surface::Deformable { soil },
        (None, None) => Surface::Rigid { friction: 0.6 },
    }
}

/// The patches as the planner is told them, one class drawn per patch.
pub fn believed_patches(world: &World, m: &Confusion, rng: &mut ChaCha8Rng) -> Vec<Patch> {
    world
        .patches
        .iter()
        .map(|p| {
            let seen = draw(&m[p.semantic.id() as usize], rng);
            Patch {
                semantic: seen,
                surface: nominal_surface(seen),
            }
        })
        .collect()
}
