//! The candle SWAE: a strided-conv encoder and a mirrored decoder (BatchNorm, LeakyReLU 0.2, tanh output). The
//! decoder doubles the resolution per stage either by a transposed conv (kernel 4, stride 2: [`DecoderKind::Deconv`],
//! the v1 model, which leaves a checkerboard grid in its outputs) or by nearest-neighbour upsampling followed by a
//! 3 x 3 conv ([`DecoderKind::Upsample`], no grid). The loss is in [`crate::loss`].
//!
//! Tensor names in the weights file (what [`crate::decoder::Decoder`] reads):
//! `enc.conv{i}`, `enc.bn{i}`, `enc.fc`, `dec.fc`, `dec.bn0`, `dec.deconv{i}` or `dec.up{i}`, `dec.bn{i+1}` (no
//! BatchNorm after the last stage), each with `weight`/`bias` and BatchNorm's `running_mean`/`running_var`.

mod ops;

use crate::{SwaeError, CROP_PX};
use candle_core::{DType, Device, Module, ModuleT, Tensor};
use candle_nn::{
    batch_norm, conv2d, conv_transpose2d, linear, BatchNorm, Conv2d, Conv2dConfig, ConvTranspose2d,
    ConvTranspose2dConfig, Linear, VarBuilder, VarMap,
};
pub use ops::batch;
use ops::conv3x3_same;
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
    /// A linear path beside the convolutional ones (`enc.lin`: crop -> latent, `dec.lin`: latent -> crop), set to
    /// the training crops' whitened PCA when training starts and then frozen; the conv paths (whose last layers
    /// start at zero) learn what the linear model misses. So the model starts where a PCA of the latent's size is
    /// and training moves it from there.
    #[serde(default)]
    pub linear_skip: bool,
    /// An observation model (`detail.kernel`, [`crate::detail`]): the residual field that samples add to the
    /// decoder's mean, refitted at every checkpoint.
    #[serde(default)]
    pub detail: bool,
    /// Channels of a full-resolution refiner (0: none): three 3 x 3 convs (1 -> c -> c -> 1, LeakyReLU between,
    /// the last starting at zero) whose output is added to the decoded map, so it learns what sharpens the
    /// smooth decoded relief (ridges, valleys) from the map itself, the same everywhere on it.
    #[serde(default)]
    pub refiner: usize,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            channels: vec![8, 16, 32, 64, 64],
            latent: 64,
            decoder: DecoderKind::Upsample,
            linear_skip: false,
            detail: false,
            refiner: 0,
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
    /// `(enc.lin, dec.lin)` when [`Config::linear_skip`].
    skip: Option<(Linear, Linear)>,
    /// `detail.kernel` and `detail.marginal` when [`Config::detail`].
    detail: Option<(Tensor, Tensor, Tensor)>,
    /// `ref.conv0..2` when [`Config::refiner`] > 0.
    refiner: Vec<Conv2d>,
}

/// Variables set from data rather than trained: the linear skip (from a PCA) and the detail kernel (fitted).
pub fn is_fitted(name: &str) -> bool {
    name.starts_with("enc.lin.") || name.starts_with("dec.lin.") || name.starts_with("detail.")
}

/// Variables of the convolutional encoder and decoder paths (everything but the linear skip, the refiner and the
/// detail kernel).
pub fn is_conv_path(name: &str) -> bool {
    [
        "enc.conv",
        "enc.bn",
        "enc.fc",
        "dec.fc",
        "dec.bn",
        "dec.up",
        "dec.deconv",
    ]
    .iter()
    .any(|p| name.starts_with(p))
}

impl Swae {
    /// A fresh model with weights drawn from `rng` (so a training run is reproducible for a thread count).
    pub fn new(config: Config, rng: &mut ChaCha8Rng) -> Result<Swae, SwaeError> {
        config.validate()?;
        let varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &Device::Cpu);
        let model = Self::build(config, varmap.clone(), vb)?;
        model.reinit(rng)?;
        if let Some(last) = model.refiner.last() {
            // The refiner starts as the identity (its correction zero).
            model
                .var_of(last.weight())?
                .set(&last.weight().zeros_like()?)?;
        }
        Ok(model)
    }

    /// Loads a model from a weights file written by [`Swae::save`].
    pub fn load(path: &std::path::Path) -> Result<Swae, SwaeError> {
        let dec = crate::decoder::Decoder::load(path)?;
        let config = Config {
            channels: dec.encoder_channels(),
            latent: dec.latent(),
            decoder: dec.kind(),
            linear_skip: dec.has_linear_skip(),
            detail: dec.detail().is_some(),
            refiner: dec.refiner_channels(),
        };
        config.validate()?;
        let varmap = VarMap::new();
        let vb = VarBuilder::from_varmap(&varmap, DType::F32, &Device::Cpu);
        let model = Self::build(config, varmap.clone(), vb)?;
        // As `VarMap::load`, except that `detail.marginal` and `detail.amplitude` may be missing (files written
        // before them: no transform, a stationary field).
        let bad = |message: String| SwaeError::Weights {
            path: path.into(),
            message,
        };
        let file =
            candle_core::safetensors::load(path, &Device::Cpu).map_err(|e| bad(e.to_string()))?;
        for (name, var) in varmap.data().lock().expect("varmap lock").iter() {
            match file.get(name) {
                Some(t) if t.dims() == var.dims() => var.set(&t.to_dtype(DType::F32)?)?,
                Some(t) => {
                    return Err(bad(format!(
                        "tensor `{name}` has shape {:?}, the model {:?}",
                        t.dims(),
                        var.dims()
                    )))
                }
                None if name == "detail.marginal" || name == "detail.amplitude" => {}
                None => return Err(bad(format!("missing tensor `{name}`"))),
            }
        }
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
        let d = CROP_PX * CROP_PX;
        let skip = if config.linear_skip {
            Some((
                linear(d, config.latent, vb.pp("enc.lin"))?,
                linear(config.latent, d, vb.pp("dec.lin"))?,
            ))
        } else {
            None
        };
        let detail = if config.detail {
            let side = crate::detail::SIDE;
            let zero = candle_nn::Init::Const(0.0);
            Some((
                vb.get_with_hints((side, side), "detail.kernel", zero)?,
                vb.get_with_hints((2, crate::detail::KNOTS), "detail.marginal", zero)?,
                vb.get_with_hints(1, "detail.amplitude", zero)?,
            ))
        } else {
            None
        };
        let mut refiner = Vec::new();
        if config.refiner > 0 {
            let c = config.refiner;
            for (i, (a, b)) in [(1, c), (c, c), (c, 1)].into_iter().enumerate() {
                refiner.push(conv2d(a, b, 3, same, vb.pp(format!("ref.conv{i}")))?);
            }
        }
        Ok(Swae {
            refiner,
            config,
            varmap,
            enc_convs,
            enc_fc,
            dec_fc,
            dec_bn0,
            dec_stages,
            skip,
            detail,
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
            // Frozen variables start at zero (set from data by `init_linear_skip` and `fit_detail`).
            if name.ends_with(".bias") || is_fitted(name) {
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
        let z = self.enc_fc.forward(&h.flatten_from(1)?)?;
        Ok(match &self.skip {
            Some((enc_lin, _)) => (z + enc_lin.forward(&x.flatten_from(1)?)?)?,
            None => z,
        })
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
        let base = match &self.skip {
            Some((_, dec_lin)) => (h + dec_lin.forward(z)?.reshape((b, 1, CROP_PX, CROP_PX))?)?,
            None => h,
        };
        if self.refiner.is_empty() {
            return Ok(base);
        }
        let mut r = base.clone();
        for (i, conv) in self.refiner.iter().enumerate() {
            r = conv3x3_same(&r, conv)?;
            if i + 1 < self.refiner.len() {
                r = candle_nn::ops::leaky_relu(&r, LEAKY)?;
            }
        }
        Ok((base + r)?)
    }

    /// Sets the linear skip to the whitened PCA of `pca` (encoder: `z_i = u_i . (x - mean) / sqrt(var_i)`,
    /// decoder: `mean + sum_i sqrt(var_i) z_i u_i`) and zeroes the conv paths' last layers (`enc.fc`, the last
    /// decoder stage), so the model reconstructs exactly as the PCA does until training changes the conv paths.
    pub fn init_linear_skip(&self, pca: &crate::eval::Pca) -> Result<(), SwaeError> {
        let Some((enc_lin, dec_lin)) = &self.skip else {
            return Err(SwaeError::param(
                "linear_skip",
                "this model has no linear skip",
            ));
        };
        let (k, d) = (self.config.latent, CROP_PX * CROP_PX);
        if pca.basis.len() != k {
            return Err(SwaeError::param(
                "linear_skip",
                format!("PCA has {} components, the latent {k}", pca.basis.len()),
            ));
        }
        let mut enc_w = vec![0f32; k * d];
        let mut enc_b = vec![0f32; k];
        let mut dec_w = vec![0f32; d * k];
        for (i, (u, var)) in pca.basis.iter().zip(&pca.variance).enumerate() {
            let s = var.sqrt().max(1e-9);
            let mut b = 0.0;
            for (j, (uj, mj)) in u.iter().zip(&pca.mean).enumerate() {
                enc_w[i * d + j] = (uj / s) as f32;
                b -= uj * mj / s;
                dec_w[j * k + i] = (uj * s) as f32;
            }
            enc_b[i] = b as f32;
        }
        let dec_b: Vec<f32> = pca.mean.iter().map(|&m| m as f32).collect();
        let cpu = &Device::Cpu;
        let set = |t: &Tensor, v: Tensor| -> Result<(), SwaeError> {
            let var = self.var_of(t)?;
            var.set(&v)?;
            Ok(())
        };
        set(enc_lin.weight(), Tensor::from_vec(enc_w, (k, d), cpu)?)?;
        set(
            enc_lin.bias().expect("linear has a bias"),
            Tensor::from_vec(enc_b, k, cpu)?,
        )?;
        set(dec_lin.weight(), Tensor::from_vec(dec_w, (d, k), cpu)?)?;
        set(
            dec_lin.bias().expect("linear has a bias"),
            Tensor::from_vec(dec_b, d, cpu)?,
        )?;
        let zero = |t: &Tensor| set(t, Tensor::zeros(t.dims(), DType::F32, cpu)?);
        zero(self.enc_fc.weight())?;
        zero(self.enc_fc.bias().expect("linear has a bias"))?;
        let (last, _) = self.dec_stages.last().expect("validated");
        let conv = match last {
            Stage::Deconv(c) => (c.weight(), c.bias()),
            Stage::Upsample(c) => (c.weight(), c.bias()),
        };
        zero(conv.0)?;
        if let Some(b) = conv.1 {
            zero(b)?;
        }
        Ok(())
    }

    /// Sets the detail kernel (`SIDE x SIDE`).
    pub fn set_detail(&self, detail: &crate::detail::Detail) -> Result<(), SwaeError> {
        let Some((kernel, marginal, amplitude)) = &self.detail else {
            return Err(SwaeError::param(
                "detail",
                "this model has no detail kernel",
            ));
        };
        let (side, knots) = (crate::detail::SIDE, crate::detail::KNOTS);
        let f32s = |v: &[f64]| v.iter().map(|&k| k as f32).collect::<Vec<f32>>();
        self.var_of(kernel)?.set(&Tensor::from_vec(
            f32s(&detail.kernel),
            (side, side),
            &Device::Cpu,
        )?)?;
        let m = if detail.marginal.len() == 2 * knots {
            f32s(&detail.marginal)
        } else {
            vec![0.0; 2 * knots]
        };
        self.var_of(marginal)?
            .set(&Tensor::from_vec(m, (2, knots), &Device::Cpu)?)?;
        self.var_of(amplitude)?.set(&Tensor::from_vec(
            vec![detail.amplitude as f32],
            1,
            &Device::Cpu,
        )?)?;
        Ok(())
    }

    /// The variable of `varmap` behind a layer's tensor (same storage).
    fn var_of(&self, t: &Tensor) -> Result<candle_core::Var, SwaeError> {
        let data = self.varmap.data().lock().expect("varmap lock");
        data.values()
            .find(|v| v.as_tensor().id() == t.id())
            .cloned()
            .ok_or_else(|| SwaeError::param("model", "a layer's tensor is not in the varmap"))
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
