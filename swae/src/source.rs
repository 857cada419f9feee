//! [`SwaeSource`]: heights of generated worlds from the trained decoder.
//!
//! For a world seed: z ~ N(0, I) from `ChaCha8Rng::seed_from_u64(seed)`, decoded by the plain-Rust
//! [`Decoder`] to 128 x 128 values (plus the observation model's residual field where the weights have one,
//! clipped to [-1, 1]); mapped like the original (`(x + 1) / 2`, i.e. gray / 255) and
//! resized bilinearly to 129 x 129 samples at 1 m (corner-aligned); heights = that value times
//! [`FULL_SCALE_HEIGHT`] times the level's fraction (30 / 60 / 100 %). Image row 0 is the north edge.

use crate::{Decoder, SwaeError, CROP_PX};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use sha2::{Digest, Sha256};
use sim_core::world::{ElevationLevel, Heightmap, MAP_PX};
use std::path::Path;
use tasks::generate::HeightSource;
use tasks::TasksError;

/// The committed weights (`swae/weights/swae-v4.safetensors`: v3's linear skip and refiner with the
/// scale-mixture observation model of BENCHMARKS.md "SWAE v4", refitted by `vb terrain fit-detail`), compiled in.
pub const DEFAULT_WEIGHTS: &[u8] = include_bytes!("../weights/swae-v4.safetensors");
/// Where [`DEFAULT_WEIGHTS`] came from (relative to the workspace root), for messages.
pub const DEFAULT_WEIGHTS_PATH: &str = "swae/weights/swae-v4.safetensors";

/// Height, m, of a decoded value of +1 at the high level (the original used 16 m for gray 255).
///
/// Derived with `vb terrain calibrate` (`swae::eval::calibrate`): decode the 100 worlds of the committed seed at
/// unit height and pick the scale (to 0.01 m) minimising the largest relative error of the per-level means of
/// relief, height std, slope p50, slope p95 and roughness against all 100 original worlds
/// (`tasks::stats::ORIGINAL_WORLDS`). For `swae-v4.safetensors` that gives 11.74 m with every error within 10.9 %
/// (relief -11 / -7 / -3 %, slope p50 +7 / +9 / +11 %, slope p95 +2 / +6 / +9 %, height std +2 / +8 / +7 %,
/// roughness -7 / -1 / +1 %; BENCHMARKS.md). Tested to match the calibration. (`swae-v3.safetensors`, whose
/// stationary texture gave set v3, was calibrated at [`V3_FULL_SCALE_HEIGHT`]; `swae-v1.safetensors` at 50.48 m
/// on relief and slope p95 alone.)
pub const FULL_SCALE_HEIGHT: f64 = 11.74;

/// The calibration of `swae-v3.safetensors` (largest error 12.9 %): with those weights it regenerates task set v3.
pub const V3_FULL_SCALE_HEIGHT: f64 = 11.32;

/// The SWAE height source.
pub struct SwaeSource {
    decoder: Decoder,
    hash: String,
    /// Height of a decoded +1 at the high level, m.
    pub full_scale: f64,
}

impl SwaeSource {
    /// The committed weights and calibration.
    pub fn committed() -> Result<SwaeSource, SwaeError> {
        Self::from_bytes(
            DEFAULT_WEIGHTS,
            Path::new(DEFAULT_WEIGHTS_PATH),
            FULL_SCALE_HEIGHT,
        )
    }

    /// A weights file and a full-scale height.
    pub fn from_file(path: &Path, full_scale: f64) -> Result<SwaeSource, SwaeError> {
        let bytes = std::fs::read(path).map_err(|e| SwaeError::io(path, e))?;
        Self::from_bytes(&bytes, path, full_scale)
    }

    pub fn from_bytes(bytes: &[u8], path: &Path, full_scale: f64) -> Result<SwaeSource, SwaeError> {
        if !(full_scale.is_finite() && full_scale > 0.0) {
            return Err(SwaeError::param("full_scale", "must be positive"));
        }
        let decoder = Decoder::from_bytes(bytes, path)?;
        let digest = Sha256::digest(bytes);
        let hash: String = digest.iter().take(8).map(|b| format!("{b:02x}")).collect();
        Ok(SwaeSource {
            decoder,
            hash,
            full_scale,
        })
    }

    pub fn decoder(&self) -> &Decoder {
        &self.decoder
    }

    /// First 16 hex digits of the weights file's SHA-256.
    pub fn weights_hash(&self) -> &str {
        &self.hash
    }

    /// The latent code of a seed.
    pub fn latent(&self, seed: u64) -> Vec<f64> {
        self.draw_latent(&mut ChaCha8Rng::seed_from_u64(seed))
    }

    /// z ~ N(0, I): the first draws of a seed's stream.
    fn draw_latent(&self, rng: &mut ChaCha8Rng) -> Vec<f64> {
        (0..self.decoder.latent())
            .map(|_| rng.sample(StandardNormal))
            .collect()
    }

    /// The generative model's 128 x 128 sample for a seed, in [-1, 1]: the latent code (as [`Self::latent`]),
    /// decoded, plus the observation model's residual field drawn from the same stream after the code, where the
    /// weights have one ([`Decoder::sample`]).
    pub fn sample(&self, seed: u64) -> Result<Vec<f64>, SwaeError> {
        Ok(self.mean_and_sample(seed)?.1)
    }

    /// The decoder's mean for a seed's code and the sample [`Self::sample`] draws around it.
    pub fn mean_and_sample(&self, seed: u64) -> Result<(Vec<f64>, Vec<f64>), SwaeError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let z = self.draw_latent(&mut rng);
        let mean = self.decoder.decode(&z)?;
        let sample = self.decoder.sample_around(mean.clone(), &mut rng);
        Ok((mean, sample))
    }

    /// Sampled 129 x 129 map in [0, 1] (`(x + 1) / 2`), row 0 = north, before height scaling.
    pub fn unit_map(&self, seed: u64) -> Result<Vec<f64>, SwaeError> {
        let d = self.sample(seed)?;
        Ok(resize_bilinear(&d, CROP_PX, MAP_PX)
            .into_iter()
            .map(|v| (v + 1.0) * 0.5)
            .collect())
    }

    /// Heightmap at a given full-scale height.
    pub fn heightmap_at(
        &self,
        seed: u64,
        level: ElevationLevel,
        full_scale: f64,
    ) -> Result<Heightmap, SwaeError> {
        let u = self.unit_map(seed)?;
        let k = full_scale * level.fraction();
        let n = MAP_PX;
        let mut heights = vec![0f32; n * n];
        for row in 0..n {
            let iy = n - 1 - row; // image row 0 = north = largest y
            for ix in 0..n {
                heights[iy * n + ix] = (u[row * n + ix] * k) as f32;
            }
        }
        Ok(Heightmap {
            nx: n,
            ny: n,
            cell: 1.0,
            heights,
        })
    }
}

impl HeightSource for SwaeSource {
    fn name(&self) -> String {
        if self.full_scale == FULL_SCALE_HEIGHT {
            format!("swae:{}", self.hash)
        } else {
            format!("swae:{}(full_scale={})", self.hash, self.full_scale)
        }
    }

    fn heightmap(&self, seed: u64, level: ElevationLevel) -> Result<Heightmap, TasksError> {
        self.heightmap_at(seed, level, self.full_scale)
            .map_err(|e| TasksError::Param {
                field: "swae".into(),
                message: e.to_string(),
            })
    }
}

/// Corner-aligned bilinear resize of a `from x from` map to `to x to`.
pub fn resize_bilinear(src: &[f64], from: usize, to: usize) -> Vec<f64> {
    let mut out = vec![0.0; to * to];
    let r = (from - 1) as f64 / (to - 1) as f64;
    let coord = |i: usize| {
        let s = i as f64 * r;
        let i0 = (s.floor() as usize).min(from - 2);
        (i0, s - i0 as f64)
    };
    for oy in 0..to {
        let (y0, fy) = coord(oy);
        for ox in 0..to {
            let (x0, fx) = coord(ox);
            let a = src[y0 * from + x0];
            let b = src[y0 * from + x0 + 1];
            let c = src[(y0 + 1) * from + x0];
            let d = src[(y0 + 1) * from + x0 + 1];
            out[oy * to + ox] =
                (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy;
        }
    }
    out
}
