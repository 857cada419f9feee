//! The small pieces both networks are made of: `f32` tensors read from safetensors with their dtype and shape
//! checked, and dense and convolution layers evaluated in a fixed order (deterministic on every machine).

use crate::net::WeightsError;
use safetensors::tensor::{Dtype, SafeTensors};
use std::collections::BTreeMap;

#[derive(Clone, Debug)]
pub(crate) struct Layer {
    /// Row-major `[out, in]` (convolutions: `[out, in_channels, k, k]`).
    pub(crate) weight: Vec<f32>,
    pub(crate) bias: Vec<f32>,
}

/// A weights file's metadata and tensors.
pub(crate) fn open(
    bytes: &[u8],
) -> Result<(BTreeMap<String, String>, SafeTensors<'_>), WeightsError> {
    let (_, header) =
        SafeTensors::read_metadata(bytes).map_err(|e| WeightsError::Format(e.to_string()))?;
    let metadata: BTreeMap<String, String> = header
        .metadata()
        .as_ref()
        .map(|m| m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
        .unwrap_or_default();
    let st = SafeTensors::deserialize(bytes).map_err(|e| WeightsError::Format(e.to_string()))?;
    Ok((metadata, st))
}

/// The `format` a safetensors file's metadata names, if it has one.
pub(crate) fn format(bytes: &[u8]) -> Option<String> {
    let (_, header) = SafeTensors::read_metadata(bytes).ok()?;
    header.metadata().as_ref()?.get("format").cloned()
}

/// Refuses metadata whose `key` is not `expected`, for every pair, naming the first that differs.
pub(crate) fn expect_metadata(
    m: &BTreeMap<String, String>,
    pairs: &[(&'static str, &str)],
) -> Result<(), WeightsError> {
    for &(key, expected) in pairs {
        let found = m.get(key);
        if found.map(String::as_str) != Some(expected) {
            return Err(WeightsError::Metadata {
                key,
                found: found.map_or_else(|| "missing".to_string(), |f| format!("`{f}`")),
                expected: format!("`{expected}`"),
            });
        }
    }
    Ok(())
}

pub(crate) fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

pub(crate) fn shape(st: &SafeTensors<'_>, name: &'static str) -> Result<Vec<usize>, WeightsError> {
    st.tensor(name)
        .map(|t| t.shape().to_vec())
        .map_err(|_| WeightsError::Tensor {
            name,
            problem: "missing".into(),
        })
}

pub(crate) fn tensor(
    st: &SafeTensors<'_>,
    name: &'static str,
    want: &[usize],
) -> Result<Vec<f32>, WeightsError> {
    let t = st.tensor(name).map_err(|_| WeightsError::Tensor {
        name,
        problem: "missing".into(),
    })?;
    if t.dtype() != Dtype::F32 {
        return Err(WeightsError::Tensor {
            name,
            problem: format!("dtype {:?}, expected F32", t.dtype()),
        });
    }
    if t.shape() != want {
        return Err(WeightsError::Tensor {
            name,
            problem: format!("shape {:?}, expected {want:?}", t.shape()),
        });
    }
    let values: Vec<f32> = t
        .data()
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect();
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(WeightsError::Tensor {
            name,
            problem: format!("entry {i} is {}", values[i]),
        });
    }
    Ok(values)
}

pub(crate) fn layer(
    st: &SafeTensors<'_>,
    (weight, bias): (&'static str, &'static str),
    want: &[usize],
) -> Result<Layer, WeightsError> {
    Ok(Layer {
        weight: tensor(st, weight, want)?,
        bias: tensor(st, bias, &want[..1])?,
    })
}

/// A valid (no padding) convolution of `input` (`in_ch x side x side`) with a ReLU, into `out`: the hot path of the
/// policies and the crop model (no bounds test per tap), kept apart from [`conv_padded`].
pub(crate) fn conv_relu(
    l: &Layer,
    (filters, k, stride): (usize, usize, usize),
    in_ch: usize,
    side: usize,
    input: &[f32],
    out: &mut [f32],
) {
    let out_side = (side - k) / stride + 1;
    for f in 0..filters {
        let wf = &l.weight[f * in_ch * k * k..(f + 1) * in_ch * k * k];
        for y in 0..out_side {
            for x in 0..out_side {
                let mut acc = l.bias[f];
                for c in 0..in_ch {
                    for ky in 0..k {
                        let row = &input[(c * side + y * stride + ky) * side + x * stride..];
                        let wr = &wf[(c * k + ky) * k..(c * k + ky + 1) * k];
                        for (w, v) in wr.iter().zip(row) {
                            acc += w * v;
                        }
                    }
                }
                out[(f * out_side + y) * out_side + x] = acc.max(0.0);
            }
        }
    }
}

/// A convolution's shape: filters, kernel side, stride, zero padding on every side and dilation.
#[derive(Clone, Copy, Debug)]
pub(crate) struct ConvShape {
    pub(crate) filters: usize,
    pub(crate) k: usize,
    pub(crate) stride: usize,
    pub(crate) pad: usize,
    pub(crate) dilation: usize,
}

impl ConvShape {
    /// Output side for an input of `side` (PyTorch's formula).
    pub(crate) const fn out_side(&self, side: usize) -> usize {
        (side + 2 * self.pad - self.dilation * (self.k - 1) - 1) / self.stride + 1
    }
}

/// A zero-padded, strided, dilated convolution of `input` (`in_ch x side x side`) into `out`
/// (`filters x out_side x out_side`), with a ReLU where asked.
pub(crate) fn conv_padded(
    l: &Layer,
    c: ConvShape,
    in_ch: usize,
    side: usize,
    input: &[f32],
    out: &mut [f32],
    relu: bool,
) {
    let (k, o) = (c.k, c.out_side(side));
    for f in 0..c.filters {
        let wf = &l.weight[f * in_ch * k * k..(f + 1) * in_ch * k * k];
        for y in 0..o {
            for x in 0..o {
                let mut acc = l.bias[f];
                for ch in 0..in_ch {
                    for ky in 0..k {
                        let iy = (y * c.stride + ky * c.dilation) as isize - c.pad as isize;
                        if iy < 0 || iy >= side as isize {
                            continue;
                        }
                        let row = &input[(ch * side + iy as usize) * side..][..side];
                        for kx in 0..k {
                            let ix = (x * c.stride + kx * c.dilation) as isize - c.pad as isize;
                            if ix >= 0 && ix < side as isize {
                                acc += wf[(ch * k + ky) * k + kx] * row[ix as usize];
                            }
                        }
                    }
                }
                out[(f * o + y) * o + x] = if relu { acc.max(0.0) } else { acc };
            }
        }
    }
}

/// `out = W input + b`, then tanh where asked.
pub(crate) fn dense(l: &Layer, input: &[f32], out: &mut [f32], tanh: bool) {
    let n = input.len();
    for (o, v) in out.iter_mut().enumerate() {
        let acc = l.bias[o]
            + l.weight[o * n..(o + 1) * n]
                .iter()
                .zip(input)
                .map(|(w, x)| w * x)
                .sum::<f32>();
        *v = if tanh { acc.tanh() } else { acc };
    }
}
