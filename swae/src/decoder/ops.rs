//! The decoder's arithmetic kernels: transposed and upsampling convolutions, 3x3 convolution, biases, batch norm
//! with leaky ReLU, each in a fixed loop order (bit-identical on every machine).

use super::{Affine, Stage};
use crate::LEAKY;

/// Transposed conv, kernel 4, stride 2, padding 1: input (iy, ix) adds to output (2 iy - 1 + ky, 2 ix - 1 + kx).
pub(super) fn transposed_conv(h: &[f64], side: usize, d: &Stage, out: &mut [f64]) {
    let out_side = 2 * side;
    for ic in 0..d.cin {
        let plane = &h[ic * side * side..(ic + 1) * side * side];
        for oc in 0..d.cout {
            let k = &d.weight[(ic * d.cout + oc) * 16..(ic * d.cout + oc + 1) * 16];
            let dst = &mut out[oc * out_side * out_side..(oc + 1) * out_side * out_side];
            for iy in 0..side {
                for ky in 0..4 {
                    let oy = (2 * iy + ky) as isize - 1;
                    if oy < 0 || oy >= out_side as isize {
                        continue;
                    }
                    let drow = &mut dst[oy as usize * out_side..(oy as usize + 1) * out_side];
                    let srow = &plane[iy * side..(iy + 1) * side];
                    for (ix, &v) in srow.iter().enumerate() {
                        for kx in 0..4 {
                            let ox = (2 * ix + kx) as isize - 1;
                            if ox >= 0 && ox < out_side as isize {
                                drow[ox as usize] += v * k[ky * 4 + kx];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Nearest-neighbour x2 upsampling, then a 3 x 3 cross-correlation with zero padding 1 ([`conv3x3`] with `up` 2).
pub(super) fn upsample_conv(h: &[f64], side: usize, d: &Stage, out: &mut [f64]) {
    conv3x3(h, side, 2, d.cin, d.cout, &d.weight, out);
}

/// A 3 x 3 cross-correlation with zero padding 1 on the `side x side` input planes upsampled `up`-fold by nearest
/// neighbour (`up` 1: none): output (oc, oy, ox) adds `w[oc, ic, ky, kx] * u(ic, oy + ky - 1, ox + kx - 1)` with
/// `u(ic, y, x) = h(ic, y / up, x / up)`.
pub(super) fn conv3x3(
    h: &[f64],
    side: usize,
    up: usize,
    cin: usize,
    cout: usize,
    w: &[f64],
    out: &mut [f64],
) {
    let out_side = up * side;
    for oc in 0..cout {
        let dst = &mut out[oc * out_side * out_side..(oc + 1) * out_side * out_side];
        for ic in 0..cin {
            let plane = &h[ic * side * side..(ic + 1) * side * side];
            let k = &w[(oc * cin + ic) * 9..(oc * cin + ic + 1) * 9];
            for oy in 0..out_side {
                let drow = &mut dst[oy * out_side..(oy + 1) * out_side];
                for ky in 0..3 {
                    let uy = oy as isize + ky as isize - 1;
                    if uy < 0 || uy >= out_side as isize {
                        continue;
                    }
                    let srow = &plane[(uy as usize / up) * side..(uy as usize / up + 1) * side];
                    for (ox, o) in drow.iter_mut().enumerate() {
                        for kx in 0..3 {
                            let ux = ox as isize + kx as isize - 1;
                            if ux >= 0 && ux < out_side as isize {
                                *o += k[ky * 3 + kx] * srow[ux as usize / up];
                            }
                        }
                    }
                }
            }
        }
    }
}

/// One `side x side` plane per bias, filled with it: a layer's output before its weights add in.
pub(super) fn biased(bias: &[f64], side: usize) -> Vec<f64> {
    bias.iter()
        .flat_map(|&b| std::iter::repeat_n(b, side * side))
        .collect()
}

pub(super) fn apply_bn_leaky(h: &mut [f64], bn: &Affine, plane: usize) {
    for (c, chunk) in h.chunks_mut(plane).enumerate() {
        for v in chunk {
            let y = *v * bn.scale[c] + bn.shift[c];
            *v = if y >= 0.0 { y } else { y * LEAKY };
        }
    }
}
