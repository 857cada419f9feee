//! `vb terrain ...`: train, evaluate, calibrate and render the SWAE terrain generator (library: crate `swae`).

use clap::{Args, Subcommand};
use std::path::PathBuf;

/// `vb terrain train`'s arguments.
#[derive(clap::Args)]
pub struct TrainArgs {
    #[arg(long)]
    data: PathBuf,
    /// Weights file to write (safetensors; rewritten after every epoch).
    #[arg(long)]
    out: PathBuf,
    /// Continue the checkpoint OUT instead of starting afresh (only --epochs and --max-minutes apply).
    #[arg(long)]
    resume: bool,
    /// Length of the learning-rate schedule (with --resume: extends the checkpoint's).
    #[arg(long)]
    epochs: Option<usize>,
    #[arg(long, default_value_t = 8)]
    batch: usize,
    #[arg(long, default_value_t = 2e-3)]
    lr: f64,
    #[command(flatten)]
    model: ModelArgs,
    /// Weight of the sliced-Wasserstein term.
    #[arg(long, default_value_t = 1.0)]
    sw_weight: f64,
    /// Weight of the L1 loss on finite-difference slopes (0: off, as v1; default: swae's LossWeights::DEFAULT).
    #[arg(long)]
    gradient_weight: Option<f64>,
    /// Weight of the L1 loss on the Laplacian (0: off, as v1; default: LossWeights::DEFAULT).
    #[arg(long)]
    laplacian_weight: Option<f64>,
    /// Weight of the slope-distribution term (0: off, as v1; default: LossWeights::DEFAULT).
    #[arg(long)]
    slope_weight: Option<f64>,
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Train on the crops as they are, without random rotations and mirrors.
    #[arg(long)]
    no_augment: bool,
    /// Train only the refiner (needs --linear-skip): the conv paths keep their zero start.
    #[arg(long)]
    freeze_conv: bool,
    /// Stop after the epoch in which this many minutes have passed (0: no limit).
    #[arg(long, default_value_t = 0.0)]
    max_minutes: f64,
    /// Batches per epoch (0: all), for quick timing runs.
    #[arg(long, default_value_t = 0)]
    max_batches: usize,
}

#[derive(Subcommand)]
pub enum TerrainCmd {
    /// Train the SWAE on a directory of 128 x 128 8-bit elevation maps (the release's BenchMaps/elev_maps).
    /// Every epoch checkpoints OUT (with OUT's .optim.safetensors, .state.json and .train.log beside it);
    /// `--resume` goes on from the last completed epoch with the checkpoint's own options.
    Train(TrainArgs),
    /// Held-out reconstruction errors (vs 64-component PCA and the mean crop) and generated-vs-training
    /// height, slope and roughness distributions, as Markdown tables.
    Eval {
        #[arg(long)]
        data: PathBuf,
        /// Weights file (default: the committed swae/weights/swae-v4.safetensors).
        #[arg(long)]
        weights: Option<PathBuf>,
        /// Generated samples to compare.
        #[arg(long, default_value_t = 900)]
        samples: usize,
    },
    /// Refit a model's observation model (the texture samples add: kernel, log-amplitude and marginal law) to the
    /// residuals of its reconstructions of the training crops, and write the weights with it to OUT (the network
    /// is unchanged).
    FitDetail {
        #[arg(long)]
        data: PathBuf,
        /// Weights file to start from (default: the committed one).
        #[arg(long)]
        weights: Option<PathBuf>,
        #[arg(long)]
        out: PathBuf,
    },
    /// Derive the full-scale height from the 100 worlds of a seed (prints the constant and the per-level fit).
    Calibrate {
        #[arg(long)]
        weights: Option<PathBuf>,
        #[arg(long, default_value_t = tasks::generate::DEFAULT_SEED)]
        seed: u64,
    },
    /// Contact sheet: held-out crops, their reconstructions, generated samples and training crops (hill shade).
    Render {
        #[arg(long)]
        data: PathBuf,
        #[arg(long)]
        weights: Option<PathBuf>,
        /// Maps per row.
        #[arg(long, default_value_t = 8)]
        columns: usize,
        #[arg(long, default_value = "out/terrain/swae_contact_sheet.png")]
        out: PathBuf,
    },
}

/// The architecture options of `vb terrain train` (swae's [`swae::model::Config`]).
#[derive(Args)]
pub struct ModelArgs {
    /// Encoder channels (five stride-2 convs); the decoder mirrors them.
    #[arg(long, value_delimiter = ',', default_value = "8,16,32,64,64")]
    channels: Vec<usize>,
    #[arg(long, default_value_t = 64)]
    latent: usize,
    /// Decoder stages: `upsample` (nearest x2, then a 3 x 3 conv) or `deconv` (transposed conv, the v1 model).
    #[arg(long, default_value = "upsample")]
    decoder: swae::decoder::DecoderKind,
    /// A linear path set to the training crops' whitened PCA and frozen, beside the conv paths (which start
    /// at zero): the model starts at the PCA's reconstruction error.
    #[arg(long)]
    linear_skip: bool,
    /// An observation model: the residual field samples add to the decoder's mean, refitted every epoch.
    #[arg(long)]
    detail: bool,
    /// Channels of a full-resolution 3-conv refiner added to the decoded map (0: none).
    #[arg(long, default_value_t = 0)]
    refiner: usize,
}

#[cfg(feature = "train")]
impl From<ModelArgs> for swae::model::Config {
    fn from(a: ModelArgs) -> Self {
        swae::model::Config {
            channels: a.channels,
            latent: a.latent,
            decoder: a.decoder,
            linear_skip: a.linear_skip,
            detail: a.detail,
            refiner: a.refiner,
        }
    }
}

#[cfg(feature = "train")]
fn weights_path(w: Option<PathBuf>) -> PathBuf {
    w.unwrap_or_else(|| {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../..")
            .join(swae::source::DEFAULT_WEIGHTS_PATH)
    })
}

#[cfg(feature = "train")]
fn source(w: &std::path::Path) -> anyhow::Result<swae::SwaeSource> {
    Ok(swae::SwaeSource::from_file(
        w,
        swae::source::FULL_SCALE_HEIGHT,
    )?)
}

/// Without the `train` feature (`--no-default-features`) vb links no candle and has no terrain-model commands.
#[cfg(not(feature = "train"))]
pub fn run(_: TerrainCmd) -> anyhow::Result<()> {
    anyhow::bail!(
        "this vb was built without the terrain model's training and evaluation (candle): rebuild it with \
         `--features train` (the default)"
    )
}

#[cfg(feature = "train")]
pub fn run(cmd: TerrainCmd) -> anyhow::Result<()> {
    match cmd {
        TerrainCmd::Train(a) => train(a)?,
        TerrainCmd::Eval {
            data,
            weights,
            samples,
        } => {
            let w = weights_path(weights);
            let (train, val) = swae::train::load_split(&data)?;
            let model = swae::model::Swae::load(&w)?;
            print!(
                "{}",
                swae::eval::report(&model, &source(&w)?, &train, &val, samples)?
            );
        }
        TerrainCmd::FitDetail { data, weights, out } => {
            let w = weights_path(weights);
            let (train, _) = swae::train::load_split(&data)?;
            let model = swae::model::Swae::load(&w)?;
            let detail = swae::train::fit_detail(&model, &train)?;
            model.save(&out)?;
            println!(
                "observation model of {} refitted on {} training crops: log-amplitude sigma {:.4}, texture std {:.4}; wrote {}",
                w.display(),
                train.len().min(swae::train::DETAIL_CROPS),
                detail.amplitude,
                detail.std(),
                out.display()
            );
        }
        TerrainCmd::Calibrate { weights, seed } => {
            let (h, table) = swae::eval::calibrate(&source(&weights_path(weights))?, seed)?;
            print!("{table}");
            println!("FULL_SCALE_HEIGHT = {h:.2}");
        }
        TerrainCmd::Render {
            data,
            weights,
            columns,
            out,
        } => {
            let w = weights_path(weights);
            let img = swae::picture::contact_sheet(&data, &w, columns)?;
            if let Some(dir) = out.parent() {
                std::fs::create_dir_all(dir)?;
            }
            img.save(&out)?;
            println!("{}", out.display());
        }
    }
    Ok(())
}

/// `vb terrain train`: trains from scratch, or resumes from the last completed epoch.
#[cfg(feature = "train")]
fn train(a: TrainArgs) -> anyhow::Result<()> {
    let TrainArgs {
        data,
        out,
        resume,
        epochs,
        batch,
        lr,
        model,
        sw_weight,
        gradient_weight,
        laplacian_weight,
        slope_weight,
        seed,
        no_augment,
        freeze_conv,
        max_minutes,
        max_batches,
    } = a;
    let (train, val) = swae::train::load_split(&data)?;
    println!(
        "{} training crops, {} held out, from {}",
        train.len(),
        val.len(),
        data.display()
    );
    let log = |l: &swae::train::EpochLog| println!("{l}");
    if resume {
        swae::train::resume(&train, &val, &out, epochs, max_minutes * 60.0, log)?;
    } else {
        let defaults = swae::train::TrainOptions::default();
        let opts = swae::train::TrainOptions {
            config: model.into(),
            loss: {
                let d = swae::loss::LossWeights::DEFAULT;
                swae::loss::LossWeights {
                    sw: sw_weight,
                    gradient: gradient_weight.unwrap_or(d.gradient),
                    laplacian: laplacian_weight.unwrap_or(d.laplacian),
                    slope_distribution: slope_weight.unwrap_or(d.slope_distribution),
                    ..d
                }
            },
            batch,
            lr,
            seed,
            augment: !no_augment,
            freeze_conv,
            max_seconds: max_minutes * 60.0,
            max_batches,
            epochs: epochs.unwrap_or(defaults.epochs),
            ..defaults
        };
        swae::train::train(&train, &val, &opts, Some(&out), log)?;
    }
    println!(
        "wrote {} (state, optimiser and log beside it)",
        out.display()
    );

    Ok(())
}
