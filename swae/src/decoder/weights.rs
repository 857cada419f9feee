//! Reading a weights file into the decoder's parts, each checked against the shape the architecture needs, with
//! the tensor named in every error.

use super::{Affine, DecoderKind, Stage, Tensor};
use crate::detail::{self, Detail};
use crate::{SwaeError, BN_EPS, CROP_PX};
use safetensors::SafeTensors;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// `dec.lin`: weight `[CROP_PX^2, latent]` and bias.
pub(super) type Linear = (Vec<f64>, Vec<f64>);
/// One refiner conv: `(cin, cout, weight [cout, cin, 3, 3], bias)`.
pub(super) type RefinerConv = (usize, usize, Vec<f64>, Vec<f64>);

/// A weights file's tensors by name, as f64.
pub(super) struct Tensors {
    path: PathBuf,
    pub(super) t: BTreeMap<String, Tensor>,
}

impl Tensors {
    /// Parses the bytes of a safetensors file of F32 tensors; `path` names the source in errors.
    pub(super) fn read(bytes: &[u8], path: &Path) -> Result<Tensors, SwaeError> {
        let mut out = Tensors {
            path: PathBuf::from(path),
            t: BTreeMap::new(),
        };
        let st = SafeTensors::deserialize(bytes).map_err(|e| out.bad(e.to_string()))?;
        for (name, view) in st.tensors() {
            if view.dtype() != safetensors::Dtype::F32 {
                let msg = format!("tensor `{name}` is {:?}, expected F32", view.dtype());
                return Err(out.bad(msg));
            }
            let data: Vec<f64> = view
                .data()
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64)
                .collect();
            let shape = view.shape().to_vec();
            out.t.insert(name.clone(), Tensor { shape, data });
        }
        Ok(out)
    }

    pub(super) fn bad(&self, message: String) -> SwaeError {
        SwaeError::Weights {
            path: self.path.clone(),
            message,
        }
    }

    pub(super) fn has(&self, name: &str) -> bool {
        self.t.contains_key(name)
    }

    /// Tensor `name`, of rank `rank`.
    pub(super) fn get(&self, name: &str, rank: usize) -> Result<&Tensor, SwaeError> {
        let x = self
            .t
            .get(name)
            .ok_or_else(|| self.bad(format!("missing tensor `{name}`")))?;
        if x.shape.len() != rank {
            return Err(self.bad(format!(
                "tensor `{name}` has shape {:?}, expected rank {rank}",
                x.shape
            )));
        }
        Ok(x)
    }

    /// Tensor `name`, of rank 1 and `n` values.
    pub(super) fn vector(&self, name: &str, n: usize) -> Result<&Tensor, SwaeError> {
        let x = self.get(name, 1)?;
        if x.data.len() != n {
            return Err(self.bad(format!(
                "tensor `{name}` has {} values, expected {n}",
                x.data.len()
            )));
        }
        Ok(x)
    }

    /// BatchNorm `prefix` over `c` channels, folded into an affine map.
    pub(super) fn batch_norm(&self, prefix: &str, c: usize) -> Result<Affine, SwaeError> {
        let mut parts = Vec::new();
        for f in ["weight", "bias", "running_mean", "running_var"] {
            parts.push(&self.vector(&format!("{prefix}.{f}"), c)?.data);
        }
        let (w, b, m, v) = (parts[0], parts[1], parts[2], parts[3]);
        let mut scale = vec![0.0; c];
        let mut shift = vec![0.0; c];
        for i in 0..c {
            if v[i] < 0.0 {
                return Err(self.bad(format!("`{prefix}.running_var` is negative")));
            }
            scale[i] = w[i] / (v[i] + BN_EPS).sqrt();
            shift[i] = b[i] - m[i] * scale[i];
        }
        Ok(Affine { scale, shift })
    }

    /// The `stages` resolution-doubling stages of `kind` from `cin` channels down to one.
    pub(super) fn stages(
        &self,
        kind: DecoderKind,
        stages: usize,
        mut cin: usize,
    ) -> Result<Vec<Stage>, SwaeError> {
        let mut layers = Vec::new();
        for i in 0..stages {
            let prefix = match kind {
                DecoderKind::Deconv => format!("dec.deconv{i}"),
                DecoderKind::Upsample => format!("dec.up{i}"),
            };
            let name = format!("{prefix}.weight");
            let w = self.get(&name, 4)?;
            let (win, wout, k) = match kind {
                DecoderKind::Deconv => (w.shape[0], w.shape[1], 4),
                DecoderKind::Upsample => (w.shape[1], w.shape[0], 3),
            };
            if win != cin || w.shape[2] != k || w.shape[3] != k {
                let expected = match kind {
                    DecoderKind::Deconv => format!("[{cin}, out, 4, 4]"),
                    DecoderKind::Upsample => format!("[out, {cin}, 3, 3]"),
                };
                return Err(self.bad(format!(
                    "tensor `{name}` has shape {:?}, expected {expected}",
                    w.shape
                )));
            }
            let cout = wout;
            let last = i + 1 == stages;
            if last && cout != 1 {
                return Err(self.bad(format!("tensor `{name}` must have 1 output channel")));
            }
            let b = self.vector(&format!("{prefix}.bias"), cout)?;
            layers.push(Stage {
                cin,
                cout,
                weight: w.data.clone(),
                bias: b.data.clone(),
                bn: if last {
                    None
                } else {
                    Some(self.batch_norm(&format!("dec.bn{}", i + 1), cout)?)
                },
            });
            cin = cout;
        }
        Ok(layers)
    }

    /// `dec.lin` (weight `[CROP_PX^2, latent]`, bias), if the file has it.
    pub(super) fn linear(&self, latent: usize) -> Result<Option<Linear>, SwaeError> {
        if !self.has("dec.lin.weight") {
            return Ok(None);
        }
        let w = self.get("dec.lin.weight", 2)?;
        let b = self.get("dec.lin.bias", 1)?;
        let d = CROP_PX * CROP_PX;
        if w.shape != [d, latent] {
            return Err(self.bad(format!(
                "tensor `dec.lin.weight` has shape {:?}, expected [{d}, {latent}]",
                w.shape
            )));
        }
        let b = self.vector("dec.lin.bias", d).map(|_| b)?;
        Ok(Some((w.data.clone(), b.data.clone())))
    }

    /// The observation model (`detail.kernel`, `detail.marginal`, `detail.amplitude`), if the file has one.
    pub(super) fn detail(&self) -> Result<Option<Detail>, SwaeError> {
        let Some(k) = self.t.get("detail.kernel") else {
            return Ok(None);
        };
        if k.shape != [detail::SIDE, detail::SIDE] {
            return Err(self.bad(format!(
                "tensor `detail.kernel` has shape {:?}, expected [{s}, {s}]",
                k.shape,
                s = detail::SIDE
            )));
        }
        Ok(Some(Detail {
            kernel: k.data.clone(),
            marginal: self.marginal()?,
            amplitude: self.amplitude()?,
        }))
    }

    /// The marginal transform: absent (files before it) or all zero (never fitted) means none.
    fn marginal(&self) -> Result<Vec<f64>, SwaeError> {
        Ok(match self.t.get("detail.marginal") {
            Some(m) if m.shape != [2, detail::KNOTS] => {
                return Err(self.bad(format!(
                    "tensor `detail.marginal` has shape {:?}, expected [2, {}]",
                    m.shape,
                    detail::KNOTS
                )))
            }
            Some(m) if m.data.iter().any(|&v| v != 0.0) => {
                if m.data[..detail::KNOTS].windows(2).any(|w| w[1] < w[0])
                    || m.data[detail::KNOTS..].windows(2).any(|w| w[1] < w[0])
                {
                    return Err(self.bad("`detail.marginal` knots are not increasing".into()));
                }
                m.data.clone()
            }
            _ => Vec::new(),
        })
    }

    /// The log-amplitude: absent (v3 and earlier) means a stationary field.
    fn amplitude(&self) -> Result<f64, SwaeError> {
        Ok(match self.t.get("detail.amplitude") {
            Some(a) if a.shape != [1] => {
                return Err(self.bad(format!(
                    "tensor `detail.amplitude` has shape {:?}, expected [1]",
                    a.shape
                )))
            }
            Some(a) if !(a.data[0].is_finite() && a.data[0] >= 0.0) => {
                return Err(self.bad(format!(
                    "`detail.amplitude` must be a non-negative number, not {}",
                    a.data[0]
                )))
            }
            Some(a) => a.data[0],
            None => 0.0,
        })
    }

    /// The full-resolution refiner `ref.conv0..2` (`(cin, cout, weight, bias)` per conv), if the file has one.
    pub(super) fn refiner(&self) -> Result<Vec<RefinerConv>, SwaeError> {
        let mut refiner = Vec::new();
        if !self.has("ref.conv0.weight") {
            return Ok(refiner);
        }
        let mut cin = 1;
        for i in 0..3 {
            let (wn, bn) = (format!("ref.conv{i}.weight"), format!("ref.conv{i}.bias"));
            let w = self.get(&wn, 4)?;
            let cout = w.shape[0];
            if w.shape[1..] != [cin, 3, 3] || (i == 2 && cout != 1) {
                return Err(self.bad(format!(
                    "tensor `{wn}` has shape {:?}, expected [{}, {cin}, 3, 3]",
                    w.shape,
                    if i == 2 { "1" } else { "out" }
                )));
            }
            let b = self.vector(&bn, cout)?;
            refiner.push((cin, cout, w.data.clone(), b.data.clone()));
            cin = cout;
        }
        Ok(refiner)
    }
}
