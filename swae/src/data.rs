//! Training crops: 8-bit 128 x 128 elevation maps (the release's `BenchMaps/elev_maps/*.bmp`), normalised like the
//! original (`gray / 255 * 2 - 1`, so [-1, 1]), and the fixed train/validation split.

use crate::{SwaeError, CROP_PX};
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};

/// One crop, values in [-1, 1], row-major, row 0 = the image's top row.
#[derive(Clone, Debug)]
pub struct Crop {
    pub path: PathBuf,
    pub values: Vec<f32>,
}

/// Seed of the train/validation split.
pub const SPLIT_SEED: u64 = 20_251_123;
/// Crops held out for validation.
pub const VALIDATION: usize = 100;

/// Loads every `.bmp`/`.png` in `dir`, sorted by file name (numerically where names are numbers).
pub fn load_dir(dir: &Path) -> Result<Vec<Crop>, SwaeError> {
    let entries = std::fs::read_dir(dir).map_err(|e| SwaeError::io(dir, e))?;
    let mut paths: Vec<PathBuf> = Vec::new();
    for e in entries {
        let p = e.map_err(|e| SwaeError::io(dir, e))?.path();
        let ext = p
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if ext == "bmp" || ext == "png" {
            paths.push(p);
        }
    }
    if paths.is_empty() {
        return Err(SwaeError::Data {
            path: dir.into(),
            message: "no .bmp or .png elevation maps in this directory".into(),
        });
    }
    let key = |p: &PathBuf| {
        let stem = p
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("")
            .to_string();
        (stem.parse::<u64>().unwrap_or(u64::MAX), stem)
    };
    paths.sort_by_key(key);
    paths.iter().map(|p| load_crop(p)).collect()
}

/// Loads one crop; it must be 128 x 128.
pub fn load_crop(path: &Path) -> Result<Crop, SwaeError> {
    let (w, h, v, is_image) = tasks::heightmap_io::read_samples(path)?;
    if !is_image {
        return Err(SwaeError::Data {
            path: path.into(),
            message: "expected an 8-bit image".into(),
        });
    }
    if w != CROP_PX || h != CROP_PX {
        return Err(SwaeError::Data {
            path: path.into(),
            message: format!("image is {w} x {h}, expected {CROP_PX} x {CROP_PX}"),
        });
    }
    Ok(Crop {
        path: path.into(),
        values: v.iter().map(|&g| (g * 2.0 - 1.0) as f32).collect(),
    })
}

/// Splits crops into (train, validation) with a fixed seed; `validation` crops are held out (at most half).
pub fn split(crops: Vec<Crop>, validation: usize) -> (Vec<Crop>, Vec<Crop>) {
    let n = crops.len();
    let v = validation.min(n / 2);
    let mut idx: Vec<usize> = (0..n).collect();
    idx.shuffle(&mut ChaCha8Rng::seed_from_u64(SPLIT_SEED));
    let mut val_mask = vec![false; n];
    for &i in &idx[..v] {
        val_mask[i] = true;
    }
    let (mut train, mut val) = (Vec::new(), Vec::new());
    for (i, c) in crops.into_iter().enumerate() {
        if val_mask[i] {
            val.push(c);
        } else {
            train.push(c);
        }
    }
    (train, val)
}

/// One of the 8 symmetries of the square applied to a `n x n` map (augmentation).
pub fn dihedral(src: &[f32], n: usize, k: u8) -> Vec<f32> {
    let mut out = vec![0f32; n * n];
    for y in 0..n {
        for x in 0..n {
            let (mut sx, mut sy) = (x, y);
            if k & 1 == 1 {
                sx = n - 1 - sx;
            }
            if k & 2 == 2 {
                sy = n - 1 - sy;
            }
            if k & 4 == 4 {
                std::mem::swap(&mut sx, &mut sy);
            }
            out[y * n + x] = src[sy * n + sx];
        }
    }
    out
}
