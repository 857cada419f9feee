//! The training loop behind `vb terrain train`: Adam on the loss of [`crate::loss`], random dihedral
//! augmentation, cosine learning-rate decay, BatchNorm statistics, and a checkpoint after every epoch from which
//! training resumes (`vb terrain train --resume`), so it can go on over several working days.
//!
//! A checkpoint `X.safetensors` has three files beside it: `X.optim.safetensors` (Adam's moments),
//! `X.state.json` ([`TrainState`]: options, epochs done, Adam's step, the random stream's position and the
//! weights' hash) and `X.train.log` (one line per epoch, appended). The state is written last and names the
//! weights it belongs to by hash, so a run killed while writing is refused on resume rather than continued
//! from mismatched files.
//!
//! Training is seeded (weights, shuffles, augmentation, prior samples and projections all come from one
//! `ChaCha8Rng`, whose position the state keeps), but candle's CPU kernels use several threads and their
//! summation order may vary, so two runs are not bit-identical. Generation does not depend on that: it reads the
//! committed weights.

use crate::data::{self, Crop};
use crate::loss::{self, LossWeights};
use crate::model::{self, Config, Swae};
use crate::optim::Adam;
use crate::{SwaeError, CROP_PX};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use sha2::{Digest, Sha256};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Training options.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrainOptions {
    pub config: Config,
    pub loss: LossWeights,
    /// Length of the learning-rate schedule, epochs (a resumed run may extend it).
    pub epochs: usize,
    pub batch: usize,
    pub lr: f64,
    pub seed: u64,
    /// Stop after the epoch during which this many seconds have passed (0: no limit).
    #[serde(skip)]
    pub max_seconds: f64,
    /// Random dihedral augmentation of the training crops (v1, v2). A linear-skip model is set from the PCA of
    /// the crops as they are, which is not invariant under rotation, so it trains without.
    #[serde(default = "yes")]
    pub augment: bool,
    /// Train only the refiner: the conv encoder and decoder paths stay at their start (a linear-skip model's
    /// conv paths start with zero output), so the model is its PCA plus the refiner. Needs `linear_skip`.
    #[serde(default)]
    pub freeze_conv: bool,
    /// Stop after this many batches per epoch (0: all); for smoke tests.
    #[serde(default)]
    pub max_batches: usize,
    /// Stop after this many epochs in this session (0: no limit); the schedule still runs over `epochs`.
    #[serde(skip)]
    pub session_epochs: usize,
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
            augment: true,
            freeze_conv: false,
            max_batches: 0,
            session_epochs: 0,
        }
    }
}

fn yes() -> bool {
    true
}

impl TrainOptions {
    /// Whether training leaves the variable `name` alone: the fitted ones always, the conv paths when
    /// [`TrainOptions::freeze_conv`].
    pub fn is_frozen(&self, name: &str) -> bool {
        model::is_fitted(name) || (self.freeze_conv && model::is_conv_path(name))
    }
}

/// What a checkpoint needs to go on: written to `X.state.json` after every epoch.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TrainState {
    pub options: TrainOptions,
    pub epochs_done: usize,
    pub adam_step: u64,
    /// `ChaCha8Rng::get_word_pos` after the last completed epoch, as a decimal string (a u128).
    pub rng_word_pos: String,
    /// First 16 hex digits of the SHA-256 of the weights file this state belongs to.
    pub weights_sha256: String,
    /// Seconds of training so far, over all sessions.
    pub seconds: f64,
}

/// Mean losses of one epoch.
#[derive(Clone, Debug)]
pub struct EpochLog {
    pub epoch: usize,
    pub l2: f64,
    pub l1: f64,
    pub sw: f64,
    pub gradient: f64,
    pub laplacian: f64,
    pub slope_distribution: f64,
    pub val_rmse: f64,
    /// Seconds of training so far, over all sessions.
    pub seconds: f64,
}

impl std::fmt::Display for EpochLog {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "epoch {:>3}  l2 {:.5}  l1 {:.5}  sw {:.5}  grad {:.5}  lap {:.5}  slope {:.2e}  val_rmse {:.5}  {:.0} s",
            self.epoch,
            self.l2,
            self.l1,
            self.sw,
            self.gradient,
            self.laplacian,
            self.slope_distribution,
            self.val_rmse,
            self.seconds
        )
    }
}

/// A file beside the checkpoint `out`: `X.safetensors` -> `X.<suffix>`.
pub fn sidecar(out: &Path, suffix: &str) -> PathBuf {
    out.with_extension(suffix)
}

/// Trains a fresh model on `train`, reports held-out RMSE on `val` after each epoch, checkpoints to `out` after
/// each epoch (when given; the log starts afresh) and returns the model with the per-epoch logs.
pub fn train(
    train: &[Crop],
    val: &[Crop],
    opts: &TrainOptions,
    out: Option<&Path>,
    on_epoch: impl FnMut(&EpochLog),
) -> Result<(Swae, Vec<EpochLog>), SwaeError> {
    check(train, opts)?;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let model = Swae::new(opts.config.clone(), &mut rng)?;
    if opts.config.linear_skip {
        model.init_linear_skip(&crate::eval::Pca::fit(train, opts.config.latent)?)?;
    }
    let adam = Adam::new(&model.varmap, opts.lr, |n| opts.is_frozen(n))?;
    if let Some(out) = out {
        let log = sidecar(out, "train.log");
        if let Some(dir) = log.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| SwaeError::io(dir, e))?;
        }
        let header = serde_json::to_string(opts).expect("options serialise");
        std::fs::write(&log, format!("# options {header}\n"))
            .map_err(|e| SwaeError::io(&log, e))?;
    }
    run(train, val, opts, model, adam, rng, 0, 0.0, out, on_epoch)
}

/// Goes on training the checkpoint `out` (written by [`train`] or an earlier resume) from its last completed
/// epoch. `epochs` extends the schedule's length; `max_seconds` bounds this session.
pub fn resume(
    train: &[Crop],
    val: &[Crop],
    out: &Path,
    epochs: Option<usize>,
    max_seconds: f64,
    on_epoch: impl FnMut(&EpochLog),
) -> Result<(Swae, Vec<EpochLog>), SwaeError> {
    let state_path = sidecar(out, "state.json");
    let text = std::fs::read_to_string(&state_path).map_err(|e| SwaeError::io(&state_path, e))?;
    let state: TrainState = serde_json::from_str(&text).map_err(|e| SwaeError::Data {
        path: state_path.clone(),
        message: format!("invalid training state: {e}"),
    })?;
    let hash = file_hash(out)?;
    if hash != state.weights_sha256 {
        return Err(SwaeError::Data {
            path: state_path,
            message: format!(
                "belongs to weights {} but {} hashes to {hash} (interrupted while saving?): resume from a \
                 consistent checkpoint",
                state.weights_sha256,
                out.display()
            ),
        });
    }
    let mut opts = state.options.clone();
    if let Some(e) = epochs {
        opts.epochs = e;
    }
    opts.max_seconds = max_seconds;
    check(train, &opts)?;
    let model = Swae::load(out)?;
    if model.config != opts.config {
        return Err(SwaeError::Data {
            path: out.into(),
            message: format!(
                "holds a model {:?}, its state says {:?}",
                model.config, opts.config
            ),
        });
    }
    let mut adam = Adam::new(&model.varmap, opts.lr, |n| opts.is_frozen(n))?;
    adam.load(&sidecar(out, "optim.safetensors"), state.adam_step)?;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let pos: u128 = state.rng_word_pos.parse().map_err(|_| SwaeError::Data {
        path: sidecar(out, "state.json"),
        message: format!("rng_word_pos `{}` is not a number", state.rng_word_pos),
    })?;
    rng.set_word_pos(pos);
    run(
        train,
        val,
        &opts,
        model,
        adam,
        rng,
        state.epochs_done,
        state.seconds,
        Some(out),
        on_epoch,
    )
}

fn check(train: &[Crop], opts: &TrainOptions) -> Result<(), SwaeError> {
    if train.is_empty() {
        return Err(SwaeError::param("data", "no training crops"));
    }
    if opts.freeze_conv && !opts.config.linear_skip {
        return Err(SwaeError::param(
            "freeze_conv",
            "a model without a linear skip would learn nothing but its refiner on a zero map: add linear_skip",
        ));
    }
    if opts.batch < 2 {
        return Err(SwaeError::param("batch", "need at least 2 (BatchNorm)"));
    }
    opts.config.validate()
}

#[allow(clippy::too_many_arguments)]
fn run(
    train: &[Crop],
    val: &[Crop],
    opts: &TrainOptions,
    model: Swae,
    mut adam: Adam,
    mut rng: ChaCha8Rng,
    done: usize,
    seconds_before: f64,
    out: Option<&Path>,
    mut on_epoch: impl FnMut(&EpochLog),
) -> Result<(Swae, Vec<EpochLog>), SwaeError> {
    let start = Instant::now();
    let mut logs = Vec::new();
    for epoch in done + 1..=opts.epochs {
        let frac = (epoch - 1) as f64 / opts.epochs.max(1) as f64;
        adam.lr = opts.lr * (0.05 + 0.95 * 0.5 * (1.0 + (std::f64::consts::PI * frac).cos()));
        // A fresh permutation per epoch from the stream alone, so a resumed run shuffles as an unbroken one.
        let mut order: Vec<usize> = (0..train.len()).collect();
        order.shuffle(&mut rng);
        let mut sums = [0.0; 6];
        let mut nb = 0usize;
        // Drop the last incomplete batch (BatchNorm on very small batches is noisy).
        let full = (order.len() / opts.batch).max(1);
        for chunk in order.chunks(opts.batch).take(full) {
            if opts.max_batches > 0 && nb >= opts.max_batches {
                break;
            }
            let aug: Vec<Vec<f32>> = chunk
                .iter()
                .map(|&i| {
                    // The draw is made either way, so the stream does not depend on the option.
                    let k = rng.gen_range(0..8);
                    data::dihedral(&train[i].values, CROP_PX, if opts.augment { k } else { 0 })
                })
                .collect();
            let refs: Vec<&[f32]> = aug.iter().map(|v| v.as_slice()).collect();
            let x = model::batch(&refs)?;
            let l = loss::loss(&model, &x, &opts.loss, &mut rng)?;
            adam.backward_step(&l.total)?;
            for (s, v) in sums.iter_mut().zip([
                l.l2,
                l.l1,
                l.sw,
                l.gradient,
                l.laplacian,
                l.slope_distribution,
            ]) {
                *s += v as f64;
            }
            nb += 1;
        }
        let nb = nb.max(1) as f64;
        let seconds = seconds_before + start.elapsed().as_secs_f64();
        let log = EpochLog {
            epoch,
            l2: sums[0] / nb,
            l1: sums[1] / nb,
            sw: sums[2] / nb,
            gradient: sums[3] / nb,
            laplacian: sums[4] / nb,
            slope_distribution: sums[5] / nb,
            val_rmse: if val.is_empty() {
                f64::NAN
            } else {
                reconstruction_rmse(&model, val)?
            },
            seconds,
        };
        if opts.config.detail {
            fit_detail(&model, train)?;
        }
        if let Some(out) = out {
            checkpoint(out, &model, &adam, &rng, opts, epoch, seconds, &log)?;
        }
        on_epoch(&log);
        logs.push(log);
        if (opts.max_seconds > 0.0 && start.elapsed().as_secs_f64() >= opts.max_seconds)
            || (opts.session_epochs > 0 && logs.len() >= opts.session_epochs)
        {
            break;
        }
    }
    Ok((model, logs))
}

/// Writes the weights, Adam's moments, then the state naming the weights' hash, and appends the epoch's line.
#[allow(clippy::too_many_arguments)]
fn checkpoint(
    out: &Path,
    model: &Swae,
    adam: &Adam,
    rng: &ChaCha8Rng,
    opts: &TrainOptions,
    epoch: usize,
    seconds: f64,
    log: &EpochLog,
) -> Result<(), SwaeError> {
    model.save(out)?;
    adam.save(&sidecar(out, "optim.safetensors"))?;
    let state = TrainState {
        options: opts.clone(),
        epochs_done: epoch,
        adam_step: adam.step,
        rng_word_pos: rng.get_word_pos().to_string(),
        weights_sha256: file_hash(out)?,
        seconds,
    };
    let path = sidecar(out, "state.json");
    let tmp = sidecar(out, "state.json.tmp");
    let text = serde_json::to_string_pretty(&state).expect("state serialises");
    std::fs::write(&tmp, text).map_err(|e| SwaeError::io(&tmp, e))?;
    std::fs::rename(&tmp, &path).map_err(|e| SwaeError::io(&path, e))?;
    let log_path = sidecar(out, "train.log");
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&log_path)
        .map_err(|e| SwaeError::io(&log_path, e))?;
    writeln!(f, "{log}").map_err(|e| SwaeError::io(&log_path, e))
}

fn file_hash(path: &Path) -> Result<String, SwaeError> {
    let bytes = std::fs::read(path).map_err(|e| SwaeError::io(path, e))?;
    Ok(Sha256::digest(&bytes)
        .iter()
        .take(8)
        .map(|b| format!("{b:02x}"))
        .collect())
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

/// Training crops whose residuals the observation model is fitted on (the first ones in file order).
pub const DETAIL_CROPS: usize = 300;

/// Fits the model's observation model ([`crate::detail`]) to the residuals of its reconstructions of the first
/// [`DETAIL_CROPS`] training crops.
pub fn fit_detail(model: &Swae, train: &[Crop]) -> Result<crate::detail::Detail, SwaeError> {
    let crops = &train[..train.len().min(DETAIL_CROPS)];
    let residuals: Vec<Vec<f64>> = reconstruct(model, crops)?
        .iter()
        .zip(crops)
        .map(|(r, c)| {
            c.values
                .iter()
                .zip(r)
                .map(|(x, y)| (x - y) as f64)
                .collect()
        })
        .collect();
    let detail = crate::detail::Detail::fit(&residuals);
    model.set_detail(&detail)?;
    Ok(detail)
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
