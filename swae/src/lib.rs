//! Sliced-Wasserstein autoencoder (SWAE) terrain generator.
//!
//! - [`data`]: the training crops (8-bit 128 x 128 BMP/PNG elevation maps), normalised to [-1, 1], and the fixed
//!   train/validation split.
//! - [`model`]: the candle model (conv encoder, upsampling or transposed-conv decoder, BatchNorm, LeakyReLU,
//!   tanh); used for training and evaluation only.
//! - [`loss`]: pixel, gradient-domain, slope-distribution and sliced-Wasserstein terms.
//! - [`optim`]: Adam with its state in a file, so training resumes where a checkpoint left it.
//! - [`train`]: the training loop behind `vb terrain train`.
//! - [`decoder`]: a plain-Rust decoder (f64, fixed loop order, no threads) reading the same weights file; this is
//!   what generation uses, so generated heights are bit-identical on every machine and thread count.
//! - [`detail`]: the observation model, the residual field a sample adds to the decoder's mean.
//! - [`source`]: [`SwaeSource`], the task set's [`tasks::generate::HeightSource`]: seeded latent, decode, resize to
//!   129 x 129 at 1 m, scale to the elevation level.
//! - [`eval`]: reconstruction errors against PCA and mean-crop references, distribution comparisons and the
//!   height-scale calibration.
//! - [`picture`]: contact sheets of crops, reconstructions and samples.

pub mod data;
pub mod decoder;
pub mod detail;
#[cfg(feature = "train")]
pub mod eval;
#[cfg(feature = "train")]
pub mod loss;
#[cfg(feature = "train")]
pub mod model;
mod num;
#[cfg(feature = "train")]
pub mod optim;
#[cfg(feature = "train")]
pub mod picture;
pub mod source;
#[cfg(feature = "train")]
pub mod train;

pub use decoder::Decoder;
pub use source::SwaeSource;

use std::path::PathBuf;

/// Side length of the training crops and of the decoder output, px.
pub const CROP_PX: usize = 128;

/// LeakyReLU slope (encoder and decoder).
pub const LEAKY: f64 = 0.2;
/// BatchNorm epsilon.
pub const BN_EPS: f64 = 1e-5;
/// Spatial size after the encoder's last conv.
pub const BOTTOM_PX: usize = 4;

/// Every error of this crate names the file where one is involved.
#[derive(Debug, thiserror::Error)]
pub enum SwaeError {
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: {message}")]
    Data { path: PathBuf, message: String },
    #[error("{path}: invalid weights file: {message}")]
    Weights { path: PathBuf, message: String },
    #[cfg(feature = "train")]
    #[error("candle: {0}")]
    Candle(#[from] candle_core::Error),
    #[error("invalid parameter `{field}`: {message}")]
    Param { field: String, message: String },
    #[error(transparent)]
    Tasks(#[from] tasks::TasksError),
}

impl SwaeError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SwaeError::Io {
            path: path.into(),
            source,
        }
    }
    pub(crate) fn param(field: &str, message: impl Into<String>) -> Self {
        SwaeError::Param {
            field: field.into(),
            message: message.into(),
        }
    }
}
