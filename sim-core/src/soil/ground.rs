//! The undeformed ground at the soil's nodes: each node's height and terrain normal (Chrono's `GetInitHeight` and
//! `GetInitNormal`), which every contact needs for every node under a body. They are pure functions of the
//! heightmap, four bilinear lookups for the normal, and a wheel presses the same nodes for tens of steps, so a small
//! direct-mapped cache serves them: a hit returns the values computed before, bit for bit, so the cache never
//! changes a trajectory, whatever it held (a clone or a copied memory starts from any content). Allocated with the
//! grid; nothing is allocated in the step.

use crate::world::Heightmap;
use nalgebra::Vector3;

/// Slots of the cache: a step's wheels or track shoes press a few hundred nodes.
const SLOTS: usize = 4096;
const EMPTY: usize = usize::MAX;

#[derive(Clone, Copy, Debug)]
struct Entry {
    node: usize,
    height: f64,
    normal: Vector3<f64>,
}

/// Direct-mapped cache of the undeformed ground at nodes, keyed by the node's linear index.
#[derive(Clone, Debug)]
pub(super) struct GroundCache {
    slots: Vec<Entry>,
}

impl GroundCache {
    /// A cache with room for [`SLOTS`] nodes, or none (`enabled` false: a world without soil asks for none).
    pub(super) fn new(enabled: bool) -> GroundCache {
        let empty = Entry {
            node: EMPTY,
            height: 0.0,
            normal: Vector3::z(),
        };
        GroundCache {
            slots: if enabled {
                vec![empty; SLOTS]
            } else {
                Vec::new()
            },
        }
    }

    /// Undeformed height and unit terrain normal at node `node`, which lies at `(x, y)`.
    #[inline]
    pub(super) fn at(
        &mut self,
        heights: &Heightmap,
        node: usize,
        x: f64,
        y: f64,
    ) -> (f64, Vector3<f64>) {
        let compute = || (heights.height_bilinear(x, y), heights.surface_normal(x, y));
        if self.slots.is_empty() {
            return compute();
        }
        // Fibonacci hashing spreads a wheel's rows (`nx` apart) over the slots.
        let slot =
            (node as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15) >> (64 - SLOTS.trailing_zeros());
        let e = &mut self.slots[slot as usize];
        if e.node != node {
            let (height, normal) = compute();
            *e = Entry {
                node,
                height,
                normal,
            };
        }
        (e.height, e.normal)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cached_values_are_the_heightmaps_bit_for_bit_whatever_collides() {
        let h = Heightmap::from_fn(1.0, |x, y| {
            0.8 * (0.13 * x).sin() * (0.09 * y).cos() + 0.01 * x * y
        });
        let mut cache = GroundCache::new(true);
        // Far more nodes than slots, visited twice: every answer equals a fresh computation.
        for _pass in 0..2 {
            for node in (0..3 * SLOTS).step_by(7) {
                let (x, y) = (
                    (node % 500) as f64 * 0.1 - 25.0,
                    (node / 500) as f64 * 0.1 - 3.0,
                );
                let (height, normal) = cache.at(&h, node, x, y);
                assert_eq!(height.to_bits(), h.height_bilinear(x, y).to_bits());
                assert_eq!(normal, h.surface_normal(x, y));
            }
        }
        assert_eq!(
            GroundCache::new(false).at(&h, 3, 0.5, 0.5).0,
            h.height_bilinear(0.5, 0.5)
        );
    }
}
