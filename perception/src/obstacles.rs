//! Obstacle detection: at each scan, an obstacle within the sensor's range and field of view is detected with a
//! probability falling with its range, `p_max exp(-ln 2 (r / r_half)^2)`; once detected it stays in the planner's
//! map. Each scan also reports phantom obstacles (a Poisson number, uniformly placed within range, rock-sized),
//! which last that scan only.

use crate::profile::ObstacleNoise;
use crate::rng::uniform;
use rand_chacha::ChaCha8Rng;
use sim_core::world::{Obstacle, ObstacleKind, World};

/// The probability of detecting an obstacle at range `r` in one scan.
pub fn detection_probability(cfg: &ObstacleNoise, r: f64) -> f64 {
    if cfg.detection_half_range <= 0.0 {
        return cfg.detection_max;
    }
    let q = r / cfg.detection_half_range;
    cfg.detection_max * (-std::f64::consts::LN_2 * q * q).exp()
}

/// One episode's obstacle detector.
pub struct Detector {
    cfg: ObstacleNoise,
    rng: ChaCha8Rng,
    /// Whether obstacle `i` of the world has been detected.
    seen: Vec<bool>,
    /// Half size of a phantom (a release rock at this world's scale), m.
    phantom_half: [f64; 3],
}

impl Detector {
    pub fn new(cfg: ObstacleNoise, rng: ChaCha8Rng, world: &World) -> Detector {
        let s = world.scale;
        Detector {
            cfg,
            rng,
            seen: vec![false; world.obstacles.len()],
            phantom_half: [2.2 * s, 2.2 * s, 1.9 * s],
        }
    }

    /// One scan from `sensor` (x, y) with range `range`; `in_view(x, y)`: whether a point is in the field of view.
    pub fn scan(
        &mut self,
        world: &World,
        sensor: [f64; 2],
        range: f64,
        in_view: impl Fn(f64, f64) -> bool,
    ) {
        for (o, seen) in world.obstacles.iter().zip(self.seen.iter_mut()) {
            if *seen {
                continue;
            }
            let r = (o.x - sensor[0]).hypot(o.y - sensor[1]);
            if r <= range && in_view(o.x, o.y) {
                *seen = uniform(&mut self.rng) < detection_probability(&self.cfg, r);
            }
        }
    }

    /// Phantoms of one scan around `sensor`, appended to `out`.
    pub fn phantoms(
        &mut self,
        world: &World,
        sensor: [f64; 2],
        range: f64,
        out: &mut Vec<Obstacle>,
    ) {
        let lambda = self.cfg.false_positives_per_update;
        if lambda <= 0.0 {
            return;
        }
        // Poisson by inversion (small means).
        let u = uniform(&mut self.rng);
        let (mut k, mut p, mut cdf) = (0u32, (-lambda).exp(), (-lambda).exp());
        while u > cdf && k < 64 {
            k += 1;
            p *= lambda / f64::from(k);
            cdf += p;
        }
        for _ in 0..k {
            let r = range * uniform(&mut self.rng).sqrt();
            let a = std::f64::consts::TAU * uniform(&mut self.rng);
            let (x, y) = (sensor[0] + r * a.cos(), sensor[1] + r * a.sin());
            out.push(Obstacle {
                kind: ObstacleKind::Rock,
                x,
                y,
                z: world.heightmap.height_bilinear(x, y),
                yaw: std::f64::consts::TAU * uniform(&mut self.rng),
                half_extents: self.phantom_half,
            });
        }
    }

    /// The detected obstacles, in the world's order, appended to `out`.
    pub fn detected(&self, world: &World, out: &mut Vec<Obstacle>) {
        out.extend(
            world
                .obstacles
                .iter()
                .zip(&self.seen)
                .filter(|(_, s)| **s)
                .map(|(o, _)| *o),
        );
    }

    /// How many of the world's obstacles have been detected.
    pub fn detected_count(&self) -> usize {
        self.seen.iter().filter(|s| **s).count()
    }
}
