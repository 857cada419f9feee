//! Obstacles: rocks (10 / 20 / 40 for sparse / medium / dense) and trees (1 / 2 / 3), placed as in the release.
//!
//! - Rock: box-like convex boulder with half extents (2.2, 2.2, 1.9) m times a scale drawn from U(0.7, 1.2) and a
//!   random yaw (the release's collision box 4.4 x 4.4 x 3.8 m times scale).
//! - Tree: a cylinder trunk of radius 0.5 m and height 5 m (the release's 1 x 1 x 5 m box).
//! - Rules: centre at least 12 m from every start and goal point, at least max(10 m, footprint diagonal) from every
//!   other obstacle, inside the map with its whole footprint; at most 500 tries per obstacle. If an obstacle
//!   cannot be placed the whole layout is resampled (the caller also resamples when a task loses its path).
//!
//! The worlds of one terrain group share one layout placed at the group's highest density; a sparser world takes
//! its first rocks and trees ([`nested`]).
//!
//! Distances are full-scale; [`sim_core::world::World::scaled`] scales them.

use rand::Rng;
use rand_chacha::ChaCha8Rng;
use sim_core::world::{Heightmap, Obstacle, ObstacleDensity, ObstacleKind};

/// Minimum distance of an obstacle centre from every start and goal point, m.
pub const START_GOAL_CLEARANCE: f64 = 12.0;
/// Minimum centre distance between obstacles, m (or the footprint diagonal if larger).
pub const MIN_SPACING: f64 = 10.0;
/// Rock half extents before the per-rock scale, m.
pub const ROCK_HALF_EXTENTS: [f64; 3] = [2.2, 2.2, 1.9];
/// Tree trunk radius and half height, m.
pub const TREE_RADIUS: f64 = 0.5;
pub const TREE_HALF_HEIGHT: f64 = 2.5;
const MAX_TRIES: usize = 500;

/// Rock and tree counts of a density.
pub fn counts(density: ObstacleDensity) -> (usize, usize) {
    match density {
        ObstacleDensity::Sparse => (10, 1),
        ObstacleDensity::Medium => (20, 2),
        ObstacleDensity::Dense => (40, 3),
    }
}

/// Horizontal footprint radius of an obstacle (circumscribed), m.
pub fn footprint_radius(o: &Obstacle) -> f64 {
    match o.kind {
        ObstacleKind::Rock => o.half_extents[0].hypot(o.half_extents[1]),
        ObstacleKind::Tree => o.half_extents[0],
    }
}

/// Required centre distance between two obstacles.
pub fn required_spacing(a: &Obstacle, b: &Obstacle) -> f64 {
    let diag = |o: &Obstacle| 2.0 * footprint_radius(o);
    MIN_SPACING.max(diag(a)).max(diag(b))
}

/// Places the obstacles of one world, or `None` if some obstacle found no place in 500 tries.
pub fn place(
    density: ObstacleDensity,
    heightmap: &Heightmap,
    keep_clear: &[[f64; 2]],
    rng: &mut ChaCha8Rng,
) -> Option<Vec<Obstacle>> {
    let (rocks, trees) = counts(density);
    let mut placed: Vec<Obstacle> = Vec::with_capacity(rocks + trees);
    for k in 0..rocks + trees {
        let mut candidate = if k < rocks {
            let s = rng.gen_range(0.7..1.2);
            Obstacle {
                kind: ObstacleKind::Rock,
                x: 0.0,
                y: 0.0,
                z: 0.0,
                yaw: rng.gen_range(0.0..std::f64::consts::TAU),
                half_extents: ROCK_HALF_EXTENTS.map(|h| round3(h * s)),
            }
        } else {
            Obstacle {
                kind: ObstacleKind::Tree,
                x: 0.0,
                y: 0.0,
                z: 0.0,
                yaw: 0.0,
                half_extents: [TREE_RADIUS, TREE_RADIUS, TREE_HALF_HEIGHT],
            }
        };
        candidate.yaw = round3(candidate.yaw);
        let margin = footprint_radius(&candidate);
        let limit_x = heightmap.half_x() - margin;
        let limit_y = heightmap.half_y() - margin;
        let mut ok = false;
        for _ in 0..MAX_TRIES {
            candidate.x = round3(rng.gen_range(-limit_x..limit_x));
            candidate.y = round3(rng.gen_range(-limit_y..limit_y));
            let clear_of_tasks = keep_clear
                .iter()
                .all(|p| (p[0] - candidate.x).hypot(p[1] - candidate.y) >= START_GOAL_CLEARANCE);
            let spaced = placed.iter().all(|o| {
                (o.x - candidate.x).hypot(o.y - candidate.y) >= required_spacing(o, &candidate)
            });
            if clear_of_tasks && spaced {
                ok = true;
                break;
            }
        }
        if !ok {
            return None;
        }
        candidate.z = round3(heightmap.height_bilinear(candidate.x, candidate.y));
        placed.push(candidate);
    }
    Some(placed)
}

/// The obstacles of a world of `density` taken from a layout placed at a higher (or the same) density: its first
/// rocks and first trees, in placement order. Every spacing and clearance rule of the layout holds for the subset,
/// and a path around all of the layout's obstacles is a path around the subset's.
pub fn nested(layout: &[Obstacle], density: ObstacleDensity) -> Vec<Obstacle> {
    let (rocks, trees) = counts(density);
    let pick = |kind: ObstacleKind, n: usize| {
        layout
            .iter()
            .filter(move |o| o.kind == kind)
            .take(n)
            .cloned()
    };
    pick(ObstacleKind::Rock, rocks)
        .chain(pick(ObstacleKind::Tree, trees))
        .collect()
}

fn round3(v: f64) -> f64 {
    (v * 1e3).round() / 1e3
}

/// Whether a world point lies inside an obstacle footprint grown by `inflation` metres.
pub fn occupies(o: &Obstacle, x: f64, y: f64, inflation: f64) -> bool {
    let (dx, dy) = (x - o.x, y - o.y);
    match o.kind {
        ObstacleKind::Tree => dx.hypot(dy) <= o.half_extents[0] + inflation,
        ObstacleKind::Rock => {
            // Distance from the point to the rotated rectangle, compared with the inflation (rounded corners).
            let (s, c) = o.yaw.sin_cos();
            let lx = (c * dx + s * dy).abs() - o.half_extents[0];
            let ly = (-s * dx + c * dy).abs() - o.half_extents[1];
            lx.max(0.0).hypot(ly.max(0.0)) <= inflation
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn flat() -> Heightmap {
        Heightmap {
            nx: 129,
            ny: 129,
            cell: 1.0,
            heights: vec![0.0; 129 * 129],
        }
    }

    #[test]
    fn dense_layouts_respect_every_rule() {
        let keep: Vec<[f64; 2]> = (0..20)
            .map(|k| {
                let a = (k as f64 * 18.0).to_radians();
                [60.0 * a.cos(), 60.0 * a.sin()]
            })
            .collect();
        let mut placed_any = 0;
        for seed in 0..10 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let Some(obs) = place(ObstacleDensity::Dense, &flat(), &keep, &mut rng) else {
                continue;
            };
            placed_any += 1;
            assert_eq!(obs.len(), 43);
            for (i, a) in obs.iter().enumerate() {
                for p in &keep {
                    assert!((p[0] - a.x).hypot(p[1] - a.y) >= START_GOAL_CLEARANCE);
                }
                for b in &obs[i + 1..] {
                    assert!((a.x - b.x).hypot(a.y - b.y) >= required_spacing(a, b));
                }
            }
        }
        assert!(
            placed_any >= 5,
            "dense placement failed too often ({placed_any}/10)"
        );
    }

    #[test]
    fn nested_layouts_take_the_first_rocks_and_trees() {
        let keep = [[60.0, 0.0], [-60.0, 0.0]];
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let dense = place(ObstacleDensity::Dense, &flat(), &keep, &mut rng).unwrap();
        assert_eq!(nested(&dense, ObstacleDensity::Dense), dense);
        let medium = nested(&dense, ObstacleDensity::Medium);
        let sparse = nested(&dense, ObstacleDensity::Sparse);
        assert_eq!(medium.len(), 22);
        assert_eq!(&medium[..20], &dense[..20]);
        assert_eq!(&medium[20..], &dense[40..42]);
        assert_eq!(sparse.len(), 11);
        assert_eq!(&sparse[..10], &dense[..10]);
        assert_eq!(sparse[10], dense[40]);
    }

    #[test]
    fn rock_footprint_test_is_rotated_and_inflated() {
        let rock = Obstacle {
            kind: ObstacleKind::Rock,
            x: 0.0,
            y: 0.0,
            z: 0.0,
            yaw: std::f64::consts::FRAC_PI_4,
            half_extents: [2.0, 1.0, 1.0],
        };
        // Along the rotated long axis the rock reaches 2 m; across it 1 m.
        let d = std::f64::consts::FRAC_1_SQRT_2;
        assert!(occupies(&rock, 1.9 * d, 1.9 * d, 0.0));
        assert!(!occupies(&rock, 2.1 * d, 2.1 * d, 0.0));
        assert!(occupies(&rock, 2.1 * d, 2.1 * d, 0.2));
        assert!(!occupies(&rock, -1.2 * d, 1.2 * d, 0.0));
    }
}
