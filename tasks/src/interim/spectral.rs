//! The first interim height source (`--generator interim-v1`, the heights of task set v1).
//!
//! Spectral synthesis: a sum of random-phase cosine waves with log-uniform wavelengths (2.5 to 128 m) and
//! amplitudes scaled by `f^-beta`; with the default beta = 0 the power spectrum falls as 1/f (a fractal surface,
//! the usual model of natural terrain), plus a few Gaussian mounds and pits for the boulder-like relief of the
//! release's scans. The result is rescaled so that its relief equals the level's target relief (about 1.8 / 3.5 /
//! 5.9 m for low / medium / high, as measured on the original worlds). It is deterministic for a seed.
//! It is *not* learned from real terrain; task sets made with it say `generator: interim-spectral` in their
//! manifest. Measured against all 100 original worlds its heights and slopes are too broad in the body of the
//! distribution (height std +40 %, slope p50 +30 % per level), which is why v2 uses [`super::BandedSource`].

use crate::generate::HeightSource;
use crate::TasksError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sim_core::world::{ElevationLevel, Heightmap, MAP_PX};

/// Target relief per level, m (the original worlds' means).
pub fn target_relief(level: ElevationLevel) -> f64 {
    match level {
        ElevationLevel::Low => 1.8,
        ElevationLevel::Medium => 3.5,
        ElevationLevel::High => 5.9,
    }
}

/// The interim spectral height source.
#[derive(Clone, Copy, Debug)]
pub struct SpectralSource {
    /// Spectral exponent of the amplitude (amplitude ~ f^-beta).
    pub beta: f64,
}

impl Default for SpectralSource {
    fn default() -> Self {
        SpectralSource { beta: 0.0 }
    }
}

impl HeightSource for SpectralSource {
    fn name(&self) -> String {
        format!("interim-spectral(beta={})", self.beta)
    }

    fn heightmap(&self, seed: u64, level: ElevationLevel) -> Result<Heightmap, TasksError> {
        let n = MAP_PX;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut h = vec![0f64; n * n];
        let waves = 160;
        for _ in 0..waves {
            // Wavelengths from 128 m down to 2.5 m, log-uniform.
            let lambda = 2.5 * (128.0f64 / 2.5).powf(rng.gen::<f64>());
            let f = 1.0 / lambda;
            let amp = f.powf(-self.beta) * rng.gen_range(0.5..1.0);
            let dir = rng.gen_range(0.0..std::f64::consts::TAU);
            let (kx, ky) = (
                f * dir.cos() * std::f64::consts::TAU,
                f * dir.sin() * std::f64::consts::TAU,
            );
            let phase = rng.gen_range(0.0..std::f64::consts::TAU);
            for iy in 0..n {
                for ix in 0..n {
                    h[iy * n + ix] += amp * (kx * ix as f64 + ky * iy as f64 + phase).cos();
                }
            }
        }
        let mounds = rng.gen_range(6..14);
        let scale = h.iter().map(|v| v.abs()).fold(0.0, f64::max).max(1e-9);
        for _ in 0..mounds {
            let (cx, cy) = (rng.gen_range(0.0..n as f64), rng.gen_range(0.0..n as f64));
            let r = rng.gen_range(3.0..10.0);
            let a = rng.gen_range(-0.6..1.0) * scale;
            for iy in 0..n {
                for ix in 0..n {
                    let d2 = (ix as f64 - cx).powi(2) + (iy as f64 - cy).powi(2);
                    h[iy * n + ix] += a * (-d2 / (2.0 * r * r)).exp();
                }
            }
        }
        let lo = h.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = h.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Ok(super::heightmap_from(
            &h,
            target_relief(level) / (hi - lo).max(1e-9),
        ))
    }
}
