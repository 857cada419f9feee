//! Tensor helpers of the model: a 3x3 same-padding convolution and batching crops into a tensor.

use super::*;

/// A 3 x 3 cross-correlation with zero padding 1 and stride 1 (`conv.forward` computes the same function), as an
/// explicit im2col and one matrix product.
///
/// candle 0.9's CPU `conv2d` returns wrong values when channels, height and width are equal (its tiled kernel
/// mistakes the NCHW input for NHWC: huggingface/candle issue 3404, fixed after 0.9.2), which the default
/// decoder meets at 32 channels on 32 x 32 px; `tests/model.rs` compares this against the plain-Rust decoder.
pub(super) fn conv3x3_same(x: &Tensor, conv: &Conv2d) -> Result<Tensor, SwaeError> {
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
