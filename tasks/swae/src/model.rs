//! The candle SWAE: a strided-conv encoder and a mirrored decoder (BatchNorm, LeakyReLU 0.2, tanh output). The
//! decoder doubles the resolution per stage either by a transposed conv (kernel 4, stride 2: [`DecoderKind::Deconv`],
//! the v1 model, which leaves a checkerboard grid in its outputs) or by nearest-neighbour upsampling followed by a
//! 3 x 3 conv ([`DecoderKind::Upsample`], no grid). The loss is in [`crate::loss`].
//!
//! Tensor names in the weights file (what [`crate::decoder::Decoder`] reads):
//! `enc.conv{i}`, `enc.bn{i}`, `enc.fc`, `dec.fc`, `dec.bn0`, `dec.deconv{i}` or `dec.up{i}`, `dec.bn{i+1}` (no
//! BatchNorm after the last stage), each with `weight`/`bias` and BatchNorm's `running_mean`/`running_var`.

use crate::{SwaeError, CROP_PX};
use candle_core::{DType, Device, Module, ModuleT, Tensor};
use candle_nn::{
    batch_norm, conv2d, conv_transpose2d, linear, BatchNorm, Conv2d, Conv2dConfig, ConvTranspose2d,
    ConvTranspose2dConfig, Linear, VarBuilder, VarMap,
};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

pub use crate::decoder::DecoderKind;
pub use crate::{BN_EPS, BOTTOM_PX, LEAKY};

/// Architecture.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Config {
    /// Encoder channels, one stride-2 conv each (5 convs take 128 px to 4 px); the decoder mirrors them.
    pub channels: Vec<usize>,
    pub latent: usize,
    #[serde(default)]
    pub decoder: DecoderKind,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            channels: vec![8, 16, 32, 64, 64],
            latent: 64,
            decoder: DecoderKind::Upsample,
        }
    }
}

/// One decoder stage's resolution-doubling layer.
enum Stage {
    Deconv(ConvTranspose2d),
    Upsample(Conv2d),
}

impl Config {
    pub fn validate(&self) -> Result<(), SwaeError> {
        if self.channels.is_empty() || CROP_PX >> self.channels.len() != BOTTOM_PX {
            return Err(SwaeError::param(
                "channels",
                format!(
                    "need exactly {} stride-2 stages to take {CROP_PX} px to {BOTTOM_PX} px",
                    (CROP_PX / BOTTOM_PX).trailing_zeros()
                ),
            ));
        }
        if self.latent == 0 || self.channels.contains(&0) {
            return Err(SwaeError::param("latent", "sizes must be positive"));
        }
        // The encoder's convs run on candle's conv2d, which is wrong when an input's channels equal its side
        // (see `conv3x3_same`): the input of conv i has channels[i - 1] channels on CROP_PX >> i px.
        for (i, pair) in self.channels.windows(2).enumerate() {
            if pair[0] == CROP_PX >> (i + 1) {
                return Err(SwaeError::param(
                    "channels",
                    format!(
                        "{} channels on {} px: candle 0.9's conv2d miscomputes inputs whose channels equal their \
                         side; choose another width",
                        pair[0],
                        pair[0]
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The model; its variables live in `varmap`.
pub struct Swae {
    pub config: Config,
    pub varmap: VarMap,
    enc_convs: Vec<(Conv2d, BatchNorm)>,
    enc_fc: Linear,
    dec_fc: Linear,
    dec_bn0: BatchNorm,
    dec_stages: Vec<(Stage, Option<BatchNorm>)>,
}

impl Swae {
    /// A fresh model with weights drawn from `rng` (so a training run is reproducible for a thread count).
    pub fn new(config: Config, rng: &mut ChaCha8Rng) -> Result<Swae, SwaeError> {
        config.validate()?;
        let varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &Device::Cpu);
        let model = Self::build(config, varmap.clone(), vb)?;
        model.reinit(rng)?;
        Ok(model)
    }

    /// Loads a model from a weights file written by [`Swae::save`].
    pub fn load(path: &std::path::Path) -> Result<Swae, SwaeError> {
        let dec = crate::decoder::Decoder::load(path)?;
        let config = Config {
            channels: dec.encoder_channels(),
            latent: dec.latent(),
            decoder: dec.kind(),
        };
        config.validate()?;
        let mut varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &Device::Cpu);
        let model = Self::build(config, varmap.clone(), vb)?;
        varmap.load(path).map_err(|e| SwaeError::Weights {
            path: path.into(),
            message: e.to_string(),
        })?;
        Ok(model)
    }

    fn build(config: Config, varmap: VarMap, vb: VarBuilder) -> Result<Swae, SwaeError> {
        let ch = &config.channels;
        let down = Conv2dConfig {
            padding: 1,
            stride: 2,
            ..Default::default()
        };
        let up = ConvTranspose2dConfig {
            padding: 1,
            stride: 2,
            output_padding: 0,
            dilation: 1,
        };
        let mut enc_convs = Vec::new();
        let mut cin = 1;
        for (i, &c) in ch.iter().enumerate() {
            let conv = conv2d(cin, c, 4, down, vb.pp(format!("enc.conv{i}")))?;
            let bn = batch_norm(c, BN_EPS, vb.pp(format!("enc.bn{i}")))?;
            enc_convs.push((conv, bn));
            cin = c;
        }
        let flat = cin * BOTTOM_PX * BOTTOM_PX;
        let enc_fc = linear(flat, config.latent, vb.pp("enc.fc"))?;
        let dec_fc = linear(config.latent, flat, vb.pp("dec.fc"))?;
        let dec_bn0 = batch_norm(cin, BN_EPS, vb.pp("dec.bn0"))?;
        let same = Conv2dConfig {
            padding: 1,
            ..Default::default()
        };
        let mut dec_stages = Vec::new();
        let outs: Vec<usize> = ch.iter().rev().skip(1).copied().chain([1]).collect();
        for (i, &c) in outs.iter().enumerate() {
            let stage = match config.decoder {
                DecoderKind::Deconv => Stage::Deconv(conv_transpose2d(
                    cin,
                    c,
                    4,
                    up,
                    vb.pp(format!("dec.deconv{i}")),
                )?),
                DecoderKind::Upsample => {
                    Stage::Upsample(conv2d(cin, c, 3, same, vb.pp(format!("dec.up{i}")))?)
                }
            };
            let bn = if i + 1 < outs.len() {
                Some(batch_norm(c, BN_EPS, vb.pp(format!("dec.bn{}", i + 1)))?)
            } else {
                None
            };
            dec_stages.push((stage, bn));
            cin = c;
        }
        Ok(Swae {
            config,
            varmap,
            enc_convs,
            enc_fc,
            dec_fc,
            dec_bn0,
            dec_stages,
        })
    }

    /// Re-draws conv and linear weights (uniform, Kaiming bound sqrt(6 / fan_in) * gain for LeakyReLU) and zeroes
    /// their biases, in name order from `rng`; BatchNorm keeps its constant init.
    fn reinit(&self, rng: &mut ChaCha8Rng) -> Result<(), SwaeError> {
        let data = self.varmap.data().lock().expect("varmap lock");
        let mut names: Vec<&String> = data.keys().collect();
        names.sort();
        for name in names {
            if name.contains(".bn") {
                continue;
            }
            let var = &data[name];
            let dims = var.dims().to_vec();
            if name.ends_with(".bias") {
                var.set(&Tensor::zeros(dims.as_slice(), DType::F32, &Device::Cpu)?)?;
                continue;
            }
            let fan_in = if name.contains("deconv") {
                // [in, out, k, k]: each output sees in * k * k / stride^2 inputs.
                dims[0] * dims[2] * dims[3] / 4
            } else {
                dims[1..].iter().product()
            };
            let bound = (6.0 / fan_in as f64).sqrt() / (1.0 + LEAKY * LEAKY).sqrt();
            let n: usize = dims.iter().product();
            let v: Vec<f32> = (0..n)
                .map(|_| rng.gen_range(-bound..bound) as f32)
                .collect();
            var.set(&Tensor::from_vec(v, dims.as_slice(), &Device::Cpu)?)?;
        }
        Ok(())
    }

    /// `x`: `[B, 1, 128, 128]` -> `z`: `[B, latent]`.
    pub fn encode(&self, x: &Tensor, train: bool) -> Result<Tensor, SwaeError> {
        let mut h = x.clone();
        for (conv, bn) in &self.enc_convs {
            h = candle_nn::ops::leaky_relu(&bn.forward_t(&conv.forward(&h)?, train)?, LEAKY)?;
        }
        Ok(self.enc_fc.forward(&h.flatten_from(1)?)?)
    }

    /// `z`: `[B, latent]` -> `[B, 1, 128, 128]` in (-1, 1).
    pub fn decode(&self, z: &Tensor, train: bool) -> Result<Tensor, SwaeError> {
        let b = z.dim(0)?;
        let c = *self.config.channels.last().expect("validated");
        let h = self
            .dec_fc
            .forward(z)?
            .reshape((b, c, BOTTOM_PX, BOTTOM_PX))?;
        let mut h = candle_nn::ops::leaky_relu(&self.dec_bn0.forward_t(&h, train)?, LEAKY)?;
        for (stage, bn) in &self.dec_stages {
            h = match stage {
                Stage::Deconv(deconv) => deconv.forward(&h)?,
                Stage::Upsample(conv) => {
                    let (side_y, side_x) = (h.dim(2)?, h.dim(3)?);
                    conv3x3_same(&h.upsample_nearest2d(2 * side_y, 2 * side_x)?, conv)?
                }
            };
            h = match bn {
                Some(bn) => candle_nn::ops::leaky_relu(&bn.forward_t(&h, train)?, LEAKY)?,
                None => h.tanh()?,
            };
        }
        Ok(h)
    }

    /// Saves every variable (weights and BatchNorm statistics) as safetensors.
    pub fn save(&self, path: &std::path::Path) -> Result<(), SwaeError> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| SwaeError::io(dir, e))?;
        }
        self.varmap.save(path).map_err(|e| SwaeError::Weights {
            path: path.into(),
            message: e.to_string(),
        })
    }
}

/// A 3 x 3 cross-correlation with zero padding 1 and stride 1 (`conv.forward` computes the same function), as an
/// explicit im2col and one matrix product.
///
/// candle 0.9's CPU `conv2d` returns wrong values when channels, height and width are equal (its tiled kernel
/// mistakes the NCHW input for NHWC: huggingface/candle issue 3404, fixed after 0.9.2), which the default
/// decoder meets at 32 channels on 32 x 32 px; `tests/model.rs` compares this against the plain-Rust decoder.
fn conv3x3_same(x: &Tensor, conv: &Conv2d) -> Result<Tensor, SwaeError> {
    let (b, c, h, w) = x.dims4()?;
    let weight = conv.weight();
    let o = weight.dim(0)?;
    let padded = x.pad_with_zeros(2, 1, 1)?.pad_with_zeros(3, 1, 1)?;
    let mut taps = Vec::with_capacity(9);
    for ky in 0..3 {
        for kx in 0..3 {
            taps.push(padded.narrow(2, ky, h)?.narrow(3, kx, w)?);
        }
    }
    // [B, C, 9, H, W] -> [B, C * 9, H * W]: rows in the weight's (c, ky, kx) order.
    let cols = Tensor::stack(&taps, 2)?.reshape((b, c * 9, h * w))?;
    let y = weight.reshape((o, c * 9))?.broadcast_matmul(&cols)?;
    let y = y.reshape((b, o, h, w))?;
    Ok(match conv.bias() {
        Some(bias) => y.broadcast_add(&bias.reshape((1, o, 1, 1))?)?,
        None => y,
    })
}

/// Stacks crops (each `128 * 128` values) into a `[B, 1, 128, 128]` tensor.
pub fn batch(crops: &[&[f32]]) -> Result<Tensor, SwaeError> {
    let mut v = Vec::with_capacity(crops.len() * CROP_PX * CROP_PX);
    for c in crops {
        v.extend_from_slice(c);
    }
    Ok(Tensor::from_vec(
        v,
        (crops.len(), 1, CROP_PX, CROP_PX),
        &Device::Cpu,
    )?)
}
