//! The deterministic decoder used for generation: plain Rust, f64 arithmetic in a fixed loop order on one thread,
//! weights read from the safetensors file. It computes the same function as [`crate::model::Swae::decode`] in
//! evaluation mode (BatchNorm with running statistics), so its output matches candle's to float rounding
//! (tested to 1e-4), but it does not depend on candle's multithreaded GEMM, whose summation order may vary. Its
//! only transcendental function, `tanh`, is computed here from `+ - * /` (see [`tanh`]), so the result does not
//! depend on the platform's libm either.

mod ops;
mod weights;

use crate::detail::Detail;
pub use crate::num::{exp, tanh};
use crate::{SwaeError, CROP_PX};
use crate::{BOTTOM_PX, LEAKY};
use ops::*;
use std::path::Path;
use weights::Tensors;

/// How a decoder stage doubles the resolution.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DecoderKind {
    /// Transposed conv, kernel 4, stride 2, padding 1 (`dec.deconv{i}`, weight `[in, out, 4, 4]`): the v1 model.
    Deconv,
    /// Nearest-neighbour x2 upsampling, then a 3 x 3 conv with padding 1 (`dec.up{i}`, weight `[out, in, 3, 3]`).
    #[default]
    Upsample,
}

/// The names `vb terrain train --decoder` takes: serde's (`deconv`, `upsample`), as the training state writes them.
impl std::str::FromStr for DecoderKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        serde_json::from_value(serde_json::Value::String(s.into()))
            .map_err(|_| format!("unknown decoder `{s}`: use `upsample` or `deconv`"))
    }
}

struct Tensor {
    shape: Vec<usize>,
    data: Vec<f64>,
}

/// BatchNorm in evaluation mode folded into a per-channel affine map.
struct Affine {
    scale: Vec<f64>,
    shift: Vec<f64>,
}

/// One resolution-doubling stage.
struct Stage {
    cin: usize,
    cout: usize,
    /// `[cin, cout, 4, 4]` (transposed conv) or `[cout, cin, 3, 3]` (upsample + conv).
    weight: Vec<f64>,
    bias: Vec<f64>,
    bn: Option<Affine>,
}

/// The decoder half of a weights file (plus the encoder's shape, for [`crate::model::Swae::load`]).
pub struct Decoder {
    latent: usize,
    bottom_channels: usize,
    /// `[bottom * 16, latent]`
    fc_weight: Vec<f64>,
    fc_bias: Vec<f64>,
    bn0: Affine,
    kind: DecoderKind,
    stages: Vec<Stage>,
    encoder_channels: Vec<usize>,
    /// `dec.lin` (`[CROP_PX^2, latent]` weight, bias), added to the conv path's output.
    linear: Option<(Vec<f64>, Vec<f64>)>,
    /// `detail.kernel`, `detail.marginal` and `detail.amplitude`: the observation model samples add.
    detail: Option<Detail>,
    /// `ref.conv0..2`: the full-resolution refiner, `(cin, cout, weight [cout, cin, 3, 3], bias)` per conv.
    refiner: Vec<(usize, usize, Vec<f64>, Vec<f64>)>,
}

impl Decoder {
    /// Reads a weights file.
    pub fn load(path: &Path) -> Result<Decoder, SwaeError> {
        let bytes = std::fs::read(path).map_err(|e| SwaeError::io(path, e))?;
        Self::from_bytes(&bytes, path)
    }

    /// Parses weights file bytes; `path` names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Decoder, SwaeError> {
        let t = Tensors::read(bytes, path)?;
        // Encoder shape (for loading the candle model).
        let mut encoder_channels = Vec::new();
        while let Some(w) =
            t.t.get(&format!("enc.conv{}.weight", encoder_channels.len()))
        {
            encoder_channels.push(*w.shape.first().unwrap_or(&0));
        }
        let fc_w = t.get("dec.fc.weight", 2)?;
        let (flat, latent) = (fc_w.shape[0], fc_w.shape[1]);
        if latent == 0 || flat % (BOTTOM_PX * BOTTOM_PX) != 0 {
            return Err(t.bad(format!(
                "`dec.fc.weight` has shape {:?}, expected [channels * {}, latent]",
                fc_w.shape,
                BOTTOM_PX * BOTTOM_PX
            )));
        }
        let bottom_channels = flat / (BOTTOM_PX * BOTTOM_PX);
        let fc_b = t.vector("dec.fc.bias", flat)?;
        let kind = if t.has("dec.up0.weight") {
            DecoderKind::Upsample
        } else {
            DecoderKind::Deconv
        };
        let stages = (CROP_PX / BOTTOM_PX).trailing_zeros() as usize;
        Ok(Decoder {
            bn0: t.batch_norm("dec.bn0", bottom_channels)?,
            stages: t.stages(kind, stages, bottom_channels)?,
            linear: t.linear(latent)?,
            detail: t.detail()?,
            refiner: t.refiner()?,
            latent,
            bottom_channels,
            fc_weight: fc_w.data.clone(),
            fc_bias: fc_b.data.clone(),
            kind,
            encoder_channels,
        })
    }

    /// Size of the latent code.
    pub fn latent(&self) -> usize {
        self.latent
    }

    /// How the decoder's stages double the resolution (from the tensor names).
    pub fn kind(&self) -> DecoderKind {
        self.kind
    }

    /// Whether the file has a linear path beside the conv decoder (`dec.lin`).
    pub fn has_linear_skip(&self) -> bool {
        self.linear.is_some()
    }

    /// Channels of the full-resolution refiner (0: none).
    pub fn refiner_channels(&self) -> usize {
        self.refiner.first().map_or(0, |r| r.1)
    }

    /// The observation model, if the file has one.
    pub fn detail(&self) -> Option<&Detail> {
        self.detail.as_ref()
    }

    /// A sample of the generative model for the code `z`: the decoded mean plus, where the file has an
    /// observation model, a residual field drawn from `rng`; clipped to the data's range [-1, 1].
    pub fn sample(&self, z: &[f64], rng: &mut impl rand::Rng) -> Result<Vec<f64>, SwaeError> {
        Ok(self.sample_around(self.decode(z)?, rng))
    }

    /// [`Self::sample`] from the decoded mean.
    pub fn sample_around(&self, mut x: Vec<f64>, rng: &mut impl rand::Rng) -> Vec<f64> {
        if let Some(d) = &self.detail {
            for (v, e) in x.iter_mut().zip(d.synthesise(rng)) {
                *v += e;
            }
        }
        x.iter_mut().for_each(|v| *v = v.clamp(-1.0, 1.0));
        x
    }

    /// Encoder channels found in the file (empty for a decoder-only file).
    pub fn encoder_channels(&self) -> Vec<usize> {
        self.encoder_channels.clone()
    }

    /// Decodes a latent code into a 128 x 128 map (the generative model's mean), row-major: in (-1, 1) for a plain
    /// decoder (tanh output); a linear skip's sum may leave that range slightly.
    pub fn decode(&self, z: &[f64]) -> Result<Vec<f64>, SwaeError> {
        if z.len() != self.latent {
            return Err(SwaeError::param(
                "z",
                format!("latent has {} values, expected {}", z.len(), self.latent),
            ));
        }
        let c = self.bottom_channels;
        let mut side = BOTTOM_PX;
        let flat = c * side * side;
        let mut h = vec![0.0; flat];
        for (o, out) in h.iter_mut().enumerate() {
            let row = &self.fc_weight[o * self.latent..(o + 1) * self.latent];
            let mut s = self.fc_bias[o];
            for (w, x) in row.iter().zip(z) {
                s += w * x;
            }
            *out = s;
        }
        apply_bn_leaky(&mut h, &self.bn0, side * side);
        for d in &self.stages {
            let out_side = side * 2;
            let mut out = biased(&d.bias, out_side);
            match self.kind {
                DecoderKind::Deconv => transposed_conv(&h, side, d, &mut out),
                DecoderKind::Upsample => upsample_conv(&h, side, d, &mut out),
            }
            match &d.bn {
                Some(bn) => apply_bn_leaky(&mut out, bn, out_side * out_side),
                None => out.iter_mut().for_each(|v| *v = tanh(*v)),
            }
            h = out;
            side = out_side;
        }
        if let Some((w, b)) = &self.linear {
            for (p, (v, bias)) in h.iter_mut().zip(b).enumerate() {
                let row = &w[p * self.latent..(p + 1) * self.latent];
                let mut s = *bias;
                for (wi, zi) in row.iter().zip(z) {
                    s += wi * zi;
                }
                *v += s;
            }
        }
        if !self.refiner.is_empty() {
            let mut r = h.clone();
            for (i, (cin, cout, w, b)) in self.refiner.iter().enumerate() {
                let mut out = biased(b, CROP_PX);
                conv3x3(&r, CROP_PX, 1, *cin, *cout, w, &mut out);
                if i + 1 < self.refiner.len() {
                    out.iter_mut().for_each(|v| {
                        if *v < 0.0 {
                            *v *= LEAKY
                        }
                    });
                }
                r = out;
            }
            h.iter_mut().zip(&r).for_each(|(v, d)| *v += d);
        }
        Ok(h)
    }
}
