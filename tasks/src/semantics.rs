//! Semantic patches: cluster centres are sampled in patch-index space, every one of the 16 x 16 patches takes the
//! class of its nearest centre, and every patch samples its own physical surface (rigid: friction from the class's
//! Normal(mean, sd) clipped to [0.1, 1.0]; deformable: the class's Soil Contact Model set). Unlike the original
//! release, patches are never merged, so per-patch friction variety is kept.
//!
//! Cluster counts and label pools follow the release: rigid worlds draw 1..=7 clusters from the 7 rigid classes,
//! deformable worlds 1..=3 from {mud, sand, snow}, mixed worlds 2..=10 with at least one of each kind. Centres are
//! drawn from a Normal with the mean and standard deviation of the patch indices and rejected when off the grid or
//! duplicated.

use rand::seq::SliceRandom;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use sim_core::world::{Patch, Semantic, SemanticsKind, Surface, PATCHES};

/// Round to 4 decimals so the human-readable specs stay short (and exact when read back).
pub(crate) fn round4(v: f64) -> f64 {
    (v * 1e4).round() / 1e4
}

/// Samples the surface of one patch of class `semantic`.
pub fn sample_surface(semantic: Semantic, rng: &mut ChaCha8Rng) -> Surface {
    match (semantic.friction_distribution(), semantic.soil()) {
        (Some((mean, sd)), _) => {
            let normal = Normal::new(mean, sd).expect("valid friction distribution");
            Surface::Rigid {
                friction: round4(normal.sample(rng).clamp(0.1, 1.0)),
            }
        }
        (None, Some(soil)) => Surface::Deformable { soil },
        (None, None) => unreachable!("every class is rigid or deformable"),
    }
}

/// Between 1 and `pool.len()` distinct classes of `pool`, in random order.
fn distinct_classes(pool: &[Semantic], rng: &mut ChaCha8Rng) -> Vec<Semantic> {
    let k = rng.gen_range(1..=pool.len());
    let mut classes = pool.to_vec();
    classes.shuffle(rng);
    classes.truncate(k);
    classes
}

/// Class labels of the clusters of a world of the given kind.
fn cluster_labels(kind: SemanticsKind, rng: &mut ChaCha8Rng) -> Vec<Semantic> {
    match kind {
        SemanticsKind::Rigid => distinct_classes(&Semantic::RIGID, rng),
        SemanticsKind::Deformable => distinct_classes(&Semantic::DEFORMABLE, rng),
        SemanticsKind::Mixed => {
            let k = rng.gen_range(2..=10);
            let mut labels = vec![
                *Semantic::RIGID.choose(rng).expect("non-empty"),
                *Semantic::DEFORMABLE.choose(rng).expect("non-empty"),
            ];
            while labels.len() < k {
                labels.push(*Semantic::ALL.choose(rng).expect("non-empty"));
            }
            labels
        }
    }
}

/// Generates the 16 x 16 patches of a world (`patches[pi * 16 + pj]`).
pub fn generate_patches(kind: SemanticsKind, rng: &mut ChaCha8Rng) -> Vec<Patch> {
    let labels = cluster_labels(kind, rng);
    // Mean and standard deviation of the patch indices 0..16.
    let mean = (PATCHES as f64 - 1.0) / 2.0;
    let sd = ((PATCHES * PATCHES - 1) as f64 / 12.0).sqrt();
    let normal = Normal::new(mean, sd).expect("valid");
    let mut centres: Vec<(i64, i64)> = Vec::with_capacity(labels.len());
    while centres.len() < labels.len() {
        let c = (
            normal.sample(rng).round() as i64,
            normal.sample(rng).round() as i64,
        );
        let on_grid = (0..PATCHES as i64).contains(&c.0) && (0..PATCHES as i64).contains(&c.1);
        if on_grid && !centres.contains(&c) {
            centres.push(c);
        }
    }
    let mut patches = Vec::with_capacity(PATCHES * PATCHES);
    for pi in 0..PATCHES as i64 {
        for pj in 0..PATCHES as i64 {
            let nearest = centres
                .iter()
                .enumerate()
                .min_by_key(|(_, c)| (c.0 - pi).pow(2) + (c.1 - pj).pow(2))
                .map(|(k, _)| k)
                .expect("at least one centre");
            let semantic = labels[nearest];
            patches.push(Patch {
                semantic,
                surface: sample_surface(semantic, rng),
            });
        }
    }
    patches
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn kinds_use_their_label_pools_and_friction_stays_in_range() {
        for seed in 0..30 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let rigid = generate_patches(SemanticsKind::Rigid, &mut rng);
            assert!(rigid.iter().all(|p| !p.semantic.is_deformable()));
            for p in &rigid {
                let Surface::Rigid { friction } = p.surface else {
                    panic!("rigid patch with soil")
                };
                assert!((0.1..=1.0).contains(&friction));
            }
            let def = generate_patches(SemanticsKind::Deformable, &mut rng);
            assert!(def.iter().all(|p| p.semantic.is_deformable()));
            let mixed = generate_patches(SemanticsKind::Mixed, &mut rng);
            assert_eq!(mixed.len(), 256);
        }
    }

    #[test]
    fn patches_of_one_class_keep_their_own_friction() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let patches = generate_patches(SemanticsKind::Rigid, &mut rng);
        let frictions: std::collections::BTreeSet<u64> = patches
            .iter()
            .filter_map(|p| match p.surface {
                Surface::Rigid { friction } => Some(friction.to_bits()),
                _ => None,
            })
            .collect();
        assert!(
            frictions.len() > 100,
            "per-patch friction variety lost: {} distinct values",
            frictions.len()
        );
    }

    #[test]
    fn mixed_worlds_draw_both_kinds_of_cluster_label() {
        for seed in 0..50 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let labels = cluster_labels(SemanticsKind::Mixed, &mut rng);
            assert!(
                labels.iter().any(|l| l.is_deformable())
                    && labels.iter().any(|l| !l.is_deformable())
            );
        }
    }
}
