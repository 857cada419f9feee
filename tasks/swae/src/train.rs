//! The training loop behind `vb terrain train`: Adam on L2 + L1 + weight x sliced-Wasserstein, random dihedral
//! augmentation, cosine learning-rate decay, BatchNorm statistics, a checkpoint after every epoch.
//!
//! Training is seeded (weights, shuffles, augmentation, prior samples and projections all come from one
//! `ChaCha8Rng`), but candle's CPU kernels use several threads and their summation order may vary, so two runs
//! are not bit-identical. Generation does not depend on that: it reads the committed weights.

use crate::data::{self, Crop};
use crate::model::{self, Config, LossWeights, Swae};
use crate::{SwaeError, CROP_PX};
use candle_nn::{AdamW, Optimizer, ParamsAdamW};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;
use std::time::Instant;

/// Training options.
#[derive(Clone, Debug)]
pub struct TrainOptions {
    pub config: Config,
    pub loss: LossWeights,
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    pub seed: u64,
    /// Stop after the epoch during which this many seconds have passed (0: no limit).
    pub max_seconds: f64,
    /// Stop after this many batches per epoch (0: all); for smoke tests.
    pub max_batches: usize,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            config: Config::default(),
            loss: LossWeights::default(),
            epochs: 30,
            batch: 8,
            lr: 2e-3,
            seed: 1,
            max_seconds: 0.0,
            max_batches: 0,
        }
    }
}

/// Mean losses of one epoch.
#[derive(Clone, Debug)]
pub struct EpochLog {
    pub epoch: usize,
    pub l2: f64,
    pub l1: f64,
    pub sw: f64,
    pub val_rmse: f64,
    pub seconds: f64,
}

impl std::fmt::Display for EpochLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "epoch {:>3}  l2 {:.5}  l1 {:.5}  sw {:.5}  val_rmse {:.5}  {:.0} s",
            self.epoch, self.l2, self.l1, self.sw, self.val_rmse, self.seconds
        )
    }
}

/// Trains on `train`, reports held-out RMSE on `val` after each epoch, saves to `out` after each epoch
/// (when given) and returns the model with the per-epoch logs.
pub fn train(
    train: &[Crop],
    val: &[Crop],
    opts: &TrainOptions,
    out: Option<&Path>,
    mut on_epoch: impl FnMut(&EpochLog),
) -> Result<(Swae, Vec<EpochLog>), SwaeError> {
    if train.is_empty() {
        return Err(SwaeError::param("data", "no training crops"));
    }
    if opts.batch < 2 {
        return Err(SwaeError::param("batch", "need at least 2 (BatchNorm)"));
    }
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let model = Swae::new(opts.config.clone(), &mut rng)?;
    let vars: Vec<_> = model
        .varmap
        .all_vars()
        .into_iter()
        .filter(|v| !v.dims().is_empty())
        .collect();
    let mut opt = AdamW::new(
        vars,
        ParamsAdamW {
            lr: opts.lr,
            weight_decay: 0.0,
            ..Default::default()
        },
    )?;
    let start = Instant::now();
    let mut logs = Vec::new();
    let mut order: Vec<usize> = (0..train.len()).collect();
    for epoch in 1..=opts.epochs {
        let frac = (epoch - 1) as f64 / opts.epochs.max(1) as f64;
        opt.set_learning_rate(
            opts.lr * (0.05 + 0.95 * 0.5 * (1.0 + (std::f64::consts::PI * frac).cos())),
        );
        order.shuffle(&mut rng);
        let (mut s2, mut s1, mut ssw, mut nb) = (0.0, 0.0, 0.0, 0usize);
        // Drop the last incomplete batch (BatchNorm on very small batches is noisy).
        let full = (order.len() / opts.batch).max(1);
        for chunk in order.chunks(opts.batch).take(full) {
            if opts.max_batches > 0 && nb >= opts.max_batches {
                break;
            }
            let aug: Vec<Vec<f32>> = chunk
                .iter()
                .map(|&i| data::dihedral(&train[i].values, CROP_PX, rng.gen_range(0..8)))
                .collect();
            let refs: Vec<&[f32]> = aug.iter().map(|v| v.as_slice()).collect();
            let x = model::batch(&refs)?;
            let l = model::loss(&model, &x, &opts.loss, &mut rng)?;
            opt.backward_step(&l.total)?;
            s2 += l.l2 as f64;
            s1 += l.l1 as f64;
            ssw += l.sw as f64;
            nb += 1;
        }
        let nb = nb.max(1) as f64;
        let log = EpochLog {
            epoch,
            l2: s2 / nb,
            l1: s1 / nb,
            sw: ssw / nb,
            val_rmse: if val.is_empty() {
                f64::NAN
            } else {
                reconstruction_rmse(&model, val)?
            },
            seconds: start.elapsed().as_secs_f64(),
        };
        on_epoch(&log);
        logs.push(log);
        if let Some(out) = out {
            model.save(out)?;
        }
        if opts.max_seconds > 0.0 && start.elapsed().as_secs_f64() >= opts.max_seconds {
            break;
        }
    }
    Ok((model, logs))
}

/// Reconstructions (evaluation mode) of crops, each 128 x 128.
pub fn reconstruct(model: &Swae, crops: &[Crop]) -> Result<Vec<Vec<f32>>, SwaeError> {
    let mut out = Vec::with_capacity(crops.len());
    for chunk in crops.chunks(50) {
        let refs: Vec<&[f32]> = chunk.iter().map(|c| c.values.as_slice()).collect();
        let x = model::batch(&refs)?;
        let y = model.decode(&model.encode(&x, false)?, false)?;
        for row in y.flatten_from(1)?.to_vec2::<f32>()? {
            out.push(row);
        }
    }
    Ok(out)
}

/// Root-mean-square reconstruction error over crops, normalised units.
pub fn reconstruction_rmse(model: &Swae, crops: &[Crop]) -> Result<f64, SwaeError> {
    let rec = reconstruct(model, crops)?;
    let (mut s, mut n) = (0.0, 0usize);
    for (c, r) in crops.iter().zip(&rec) {
        for (a, b) in c.values.iter().zip(r) {
            s += ((a - b) as f64).powi(2);
            n += 1;
        }
    }
    Ok((s / n.max(1) as f64).sqrt())
}

/// Loads a data directory and splits it with the fixed seed.
pub fn load_split(dir: &Path) -> Result<(Vec<Crop>, Vec<Crop>), SwaeError> {
    Ok(data::split(data::load_dir(dir)?, data::VALIDATION))
}
