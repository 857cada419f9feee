//! The deterministic decoder used for generation: plain Rust, f64 arithmetic in a fixed loop order on one thread,
//! weights read from the safetensors file. It computes the same function as [`crate::model::Swae::decode`] in
//! evaluation mode (BatchNorm with running statistics), so its output matches candle's to float rounding
//! (tested to 1e-4), but it does not depend on candle's multithreaded GEMM, whose summation order may vary. Its
//! only transcendental function, `tanh`, is computed here from `+ - * /` (see [`tanh`]), so the result does not
//! depend on the platform's libm either.

mod ops;

use crate::detail::{self, Detail};
pub use crate::num::{exp, tanh};
use crate::{SwaeError, CROP_PX};
use crate::{BN_EPS, BOTTOM_PX, LEAKY};
use ops::*;
use safetensors::SafeTensors;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

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
        let bad = |message: String| SwaeError::Weights {
            path: PathBuf::from(path),
            message,
        };
        let st = SafeTensors::deserialize(bytes).map_err(|e| bad(e.to_string()))?;
        let mut t: BTreeMap<String, Tensor> = BTreeMap::new();
        for (name, view) in st.tensors() {
            if view.dtype() != safetensors::Dtype::F32 {
                return Err(bad(format!(
                    "tensor `{name}` is {:?}, expected F32",
                    view.dtype()
                )));
            }
            let data: Vec<f64> = view
                .data()
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64)
                .collect();
            t.insert(
                name.clone(),
                Tensor {
                    shape: view.shape().to_vec(),
                    data,
                },
            );
        }
        let get = |name: &str, rank: usize| -> Result<&Tensor, SwaeError> {
            let x = t
                .get(name)
                .ok_or_else(|| bad(format!("missing tensor `{name}`")))?;
            if x.shape.len() != rank {
                return Err(bad(format!(
                    "tensor `{name}` has shape {:?}, expected rank {rank}",
                    x.shape
                )));
            }
            Ok(x)
        };
        let expect_len = |name: &str, x: &Tensor, n: usize| -> Result<(), SwaeError> {
            if x.data.len() != n {
                return Err(bad(format!(
                    "tensor `{name}` has {} values, expected {n}",
                    x.data.len()
                )));
            }
            Ok(())
        };
        let bn = |prefix: &str, c: usize| -> Result<Affine, SwaeError> {
            let mut parts = Vec::new();
            for f in ["weight", "bias", "running_mean", "running_var"] {
                let name = format!("{prefix}.{f}");
                let x = get(&name, 1)?;
                expect_len(&name, x, c)?;
                parts.push(&x.data);
            }
            let (w, b, m, v) = (parts[0], parts[1], parts[2], parts[3]);
            let mut scale = vec![0.0; c];
            let mut shift = vec![0.0; c];
            for i in 0..c {
                if v[i] < 0.0 {
                    return Err(bad(format!("`{prefix}.running_var` is negative")));
                }
                scale[i] = w[i] / (v[i] + BN_EPS).sqrt();
                shift[i] = b[i] - m[i] * scale[i];
            }
            Ok(Affine { scale, shift })
        };
        // Encoder shape (for loading the candle model).
        let mut encoder_channels = Vec::new();
        while let Some(w) = t.get(&format!("enc.conv{}.weight", encoder_channels.len())) {
            encoder_channels.push(*w.shape.first().unwrap_or(&0));
        }
        let fc_w = get("dec.fc.weight", 2)?;
        let (flat, latent) = (fc_w.shape[0], fc_w.shape[1]);
        if latent == 0 || flat % (BOTTOM_PX * BOTTOM_PX) != 0 {
            return Err(bad(format!(
                "`dec.fc.weight` has shape {:?}, expected [channels * {}, latent]",
                fc_w.shape,
                BOTTOM_PX * BOTTOM_PX
            )));
        }
        let bottom_channels = flat / (BOTTOM_PX * BOTTOM_PX);
        let fc_b = get("dec.fc.bias", 1)?;
        expect_len("dec.fc.bias", fc_b, flat)?;
        let bn0 = bn("dec.bn0", bottom_channels)?;
        let stages = (CROP_PX / BOTTOM_PX).trailing_zeros() as usize;
        let kind = if t.contains_key("dec.up0.weight") {
            DecoderKind::Upsample
        } else {
            DecoderKind::Deconv
        };
        let mut layers = Vec::new();
        let mut cin = bottom_channels;
        for i in 0..stages {
            let prefix = match kind {
                DecoderKind::Deconv => format!("dec.deconv{i}"),
                DecoderKind::Upsample => format!("dec.up{i}"),
            };
            let name = format!("{prefix}.weight");
            let w = get(&name, 4)?;
            let (win, wout, k) = match kind {
                DecoderKind::Deconv => (w.shape[0], w.shape[1], 4),
                DecoderKind::Upsample => (w.shape[1], w.shape[0], 3),
            };
            if win != cin || w.shape[2] != k || w.shape[3] != k {
                let expected = match kind {
                    DecoderKind::Deconv => format!("[{cin}, out, 4, 4]"),
                    DecoderKind::Upsample => format!("[out, {cin}, 3, 3]"),
                };
                return Err(bad(format!(
                    "tensor `{name}` has shape {:?}, expected {expected}",
                    w.shape
                )));
            }
            let cout = wout;
            let last = i + 1 == stages;
            if last && cout != 1 {
                return Err(bad(format!("tensor `{name}` must have 1 output channel")));
            }
            let bname = format!("{prefix}.bias");
            let b = get(&bname, 1)?;
            expect_len(&bname, b, cout)?;
            layers.push(Stage {
                cin,
                cout,
                weight: w.data.clone(),
                bias: b.data.clone(),
                bn: if last {
                    None
                } else {
                    Some(bn(&format!("dec.bn{}", i + 1), cout)?)
                },
            });
            cin = cout;
        }
        let linear = if t.contains_key("dec.lin.weight") {
            let (w, b) = (get("dec.lin.weight", 2)?, get("dec.lin.bias", 1)?);
            let d = CROP_PX * CROP_PX;
            if w.shape != [d, latent] {
                return Err(bad(format!(
                    "tensor `dec.lin.weight` has shape {:?}, expected [{d}, {latent}]",
                    w.shape
                )));
            }
            expect_len("dec.lin.bias", b, d)?;
            Some((w.data.clone(), b.data.clone()))
        } else {
            None
        };
        let detail = match t.get("detail.kernel") {
            Some(k) if k.shape != [detail::SIDE, detail::SIDE] => {
                return Err(bad(format!(
                    "tensor `detail.kernel` has shape {:?}, expected [{s}, {s}]",
                    k.shape,
                    s = detail::SIDE
                )))
            }
            Some(k) => {
                // The marginal transform: absent (files before it) or all zero (never fitted) means none.
                let marginal = match t.get("detail.marginal") {
                    Some(m) if m.shape != [2, detail::KNOTS] => {
                        return Err(bad(format!(
                            "tensor `detail.marginal` has shape {:?}, expected [2, {}]",
                            m.shape,
                            detail::KNOTS
                        )))
                    }
                    Some(m) if m.data.iter().any(|&v| v != 0.0) => {
                        if m.data[..detail::KNOTS].windows(2).any(|w| w[1] < w[0])
                            || m.data[detail::KNOTS..].windows(2).any(|w| w[1] < w[0])
                        {
                            return Err(bad("`detail.marginal` knots are not increasing".into()));
                        }
                        m.data.clone()
                    }
                    _ => Vec::new(),
                };
                // The log-amplitude: absent (v3 and earlier) means a stationary field.
                let amplitude = match t.get("detail.amplitude") {
                    Some(a) if a.shape != [1] => {
                        return Err(bad(format!(
                            "tensor `detail.amplitude` has shape {:?}, expected [1]",
                            a.shape
                        )))
                    }
                    Some(a) if !(a.data[0].is_finite() && a.data[0] >= 0.0) => {
                        return Err(bad(format!(
                            "`detail.amplitude` must be a non-negative number, not {}",
                            a.data[0]
                        )))
                    }
                    Some(a) => a.data[0],
                    None => 0.0,
                };
                Some(Detail {
                    kernel: k.data.clone(),
                    marginal,
                    amplitude,
                })
            }
            None => None,
        };
        let mut refiner = Vec::new();
        if t.contains_key("ref.conv0.weight") {
            let mut cin = 1;
            for i in 0..3 {
                let (wn, bn) = (format!("ref.conv{i}.weight"), format!("ref.conv{i}.bias"));
                let w = get(&wn, 4)?;
                let cout = w.shape[0];
                if w.shape[1..] != [cin, 3, 3] || (i == 2 && cout != 1) {
                    return Err(bad(format!(
                        "tensor `{wn}` has shape {:?}, expected [{}, {cin}, 3, 3]",
                        w.shape,
                        if i == 2 {
                            "1".to_string()
                        } else {
                            "out".to_string()
                        }
                    )));
                }
                let b = get(&bn, 1)?;
                expect_len(&bn, b, cout)?;
                refiner.push((cin, cout, w.data.clone(), b.data.clone()));
                cin = cout;
            }
        }
        Ok(Decoder {
            refiner,
            linear,
            detail,
            latent,
            bottom_channels,
            fc_weight: fc_w.data.clone(),
            fc_bias: fc_b.data.clone(),
            bn0,
            kind,
            stages: layers,
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
