//! The decoder's observation model: the detail a 64-number latent cannot carry, as a stationary Gaussian field.
//!
//! A deterministic decoder trained on pixel losses returns the conditional mean of a crop given its code, which is
//! smoother than any crop: the fine relief that the code does not determine averages out. A SWAE (like a VAE) is a
//! generative model `p(x | z) = decoder(z) + e`; here the residual `e` is modelled as a zero-mean stationary
//! Gaussian field whose autocorrelation is measured on the training crops' residuals `x - decoder(encoder(x))`
//! (lags up to [`RADIUS`] px). A sample of the model is `decoder(z)` plus `e` drawn from that field; a
//! reconstruction is `decoder(encoder(x))` alone (the mean), which is what reconstruction errors measure.
//!
//! The field is synthesised by convolving white noise with a kernel `K` whose autocorrelation is the measured one
//! (`K * K = C`): the kernel is the inverse DFT of the square root of the power spectrum (Wiener-Khinchin; the
//! zero-phase spectral factor), computed once when the model is fitted and stored in the weights file as
//! `detail.kernel`. Generation only convolves: plain `+ *` in a fixed order, and the noise is Irwin-Hall (the sum
//! of 12 uniforms from the seeded stream, minus 6: mean 0, variance 1), so samples are bit-identical everywhere.
//! The Gaussian field's values are then mapped onto the residuals' marginal law by quantile mapping
//! ([`Detail::marginal`]), since the residuals are heavy-tailed; the map changes the autocorrelation little.
//!
//! The residuals are heavy-tailed because their local amplitude varies: a field `e = s g`, `g` the stationary
//! Gaussian field above and `s = exp(sigma a - sigma^2)` a log-normal amplitude (`a` a smooth unit Gaussian field,
//! independent of `g` and of the relief; `E[s^2] = 1`), is a Gaussian scale mixture (Andrews and Mallows, "Scale
//! mixtures of normal distributions", J. R. Stat. Soc. B 36, 1974) with kurtosis `3 E[s^4] / E[s^2]^2 =
//! 3 exp(4 sigma^2)` and slope ratio `E|grad e| / rms(grad e) = exp(-sigma^2 / 2) sqrt(pi) / 2` (0.886 for a
//! Gaussian field). [`Detail::amplitude`] is `sigma`, fitted by that kurtosis (method of moments); on the
//! release's crops it gives both the residuals' kurtosis (7.3) and their slope ratio (0.79), where a quantile-mapped
//! Gaussian field keeps the slope ratio near 0.886, i.e. too much mean slope for its rms. The kernel is then fitted
//! to the residuals' autocorrelation divided by the amplitude's, `E[s(p) s(p + l)] = exp(sigma^2 (rho_a(l) - 1))`,
//! and the quantile mapping applied to `s g`. Weights without `detail.amplitude` (v3) have `sigma = 0`: the
//! stationary field, drawn exactly as before.

use crate::CROP_PX;
use rand::{Rng, SeedableRng};

/// Largest lag of the measured autocorrelation and half-width of the kernel, px.
pub const RADIUS: usize = 12;
/// Side of the kernel, px.
pub const SIDE: usize = 2 * RADIUS + 1;
/// Periodic grid on which the autocorrelation is factorised (a power of two above twice the kernel's width).
const GRID: usize = 64;

/// Knots of the marginal transform.
pub const KNOTS: usize = 257;
/// Fields synthesised to measure the Gaussian field's quantiles when fitting the marginal transform.
const MARGINAL_FIELDS: u64 = 64;

/// Standard deviation of the Gaussian kernel that smooths white noise into the log-amplitude field `a`, px (its
/// correlation length is about twice that). The samples' slope statistics hardly depend on it between 4 and
/// 16 px (measured in `docs/analysis/swae_crops.py`).
pub const AMPLITUDE_SCALE: f64 = 6.0;
/// Half-width of that kernel, px (three standard deviations).
pub const AMPLITUDE_RADIUS: usize = 18;

/// The residual field's synthesis kernel and marginal transform.
#[derive(Clone, Debug, PartialEq)]
pub struct Detail {
    /// `SIDE x SIDE`, row-major, centred.
    pub kernel: Vec<f64>,
    /// `2 x KNOTS`: the synthesised Gaussian field's quantiles at probabilities `(i + 1/2) / KNOTS`, then the
    /// residuals' quantiles at the same probabilities; a synthesised value is mapped through the piecewise-linear
    /// function between them, so the texture has the residuals' marginal law (heavy-tailed: kurtosis about 7 on
    /// the release's crops, 3 for a Gaussian) rather than a Gaussian one: a translation process (Grigoriu,
    /// "Crossings of non-Gaussian translation processes", J. Eng. Mech. 110(4), 1984). Empty: no transform.
    pub marginal: Vec<f64>,
    /// Standard deviation `sigma` of the log-amplitude (module docs); 0: a stationary Gaussian field.
    pub amplitude: f64,
}

/// The unit-energy 1-D Gaussian kernel of the amplitude field (computed with [`crate::num::exp`], like everything
/// generation evaluates, so it is the same on every machine) (`sum k^2 = 1`, so the separable 2-D kernel's
/// output from unit white noise has unit variance), `2 AMPLITUDE_RADIUS + 1` taps.
fn amplitude_kernel() -> Vec<f64> {
    let r = AMPLITUDE_RADIUS as f64;
    let k: Vec<f64> = (0..2 * AMPLITUDE_RADIUS + 1)
        .map(|i| {
            let d = i as f64 - r;
            crate::num::exp(-d * d / (2.0 * AMPLITUDE_SCALE * AMPLITUDE_SCALE))
        })
        .collect();
    let norm = k.iter().map(|v| v * v).sum::<f64>().sqrt();
    k.into_iter().map(|v| v / norm).collect()
}

/// Autocorrelation of the unit amplitude field at lag `l` along one axis: `sum_i k_i k_(i + l)`.
fn amplitude_rho1(k: &[f64], l: usize) -> f64 {
    k.iter().zip(&k[l.min(k.len())..]).map(|(a, b)| a * b).sum()
}

/// Irwin-Hall noise: 12 uniforms from the seeded stream, minus 6 (mean 0, variance 1).
fn irwin_hall(rng: &mut impl Rng) -> f64 {
    (0..12)
        .map(|_| rng.gen::<u32>() as f64 / 4_294_967_296.0)
        .sum::<f64>()
        - 6.0
}

/// Kurtosis `E[(x - m)^4] / var^2` of the pooled values.
fn kurtosis(values: &[Vec<f64>]) -> f64 {
    let n = values.iter().map(Vec::len).sum::<usize>().max(1) as f64;
    let m = values.iter().flatten().sum::<f64>() / n;
    let (mut m2, mut m4) = (0.0, 0.0);
    for v in values.iter().flatten() {
        let d = (v - m) * (v - m);
        m2 += d;
        m4 += d * d;
    }
    let var = m2 / n;
    if var > 0.0 {
        m4 / n / (var * var)
    } else {
        3.0
    }
}

impl Detail {
    /// Measures the autocorrelation of `residuals` (each `CROP_PX * CROP_PX`, row-major) at lags up to
    /// [`RADIUS`] and factorises it into a synthesis kernel whose output has the residuals' variance.
    pub fn fit(residuals: &[Vec<f64>]) -> Detail {
        // The amplitude by the method of moments: kurtosis 3 exp(4 sigma^2); none where the tails are Gaussian or
        // lighter.
        let amplitude = (kurtosis(residuals) / 3.0).ln().max(0.0).sqrt() / 2.0;
        let mut c = autocorrelation(residuals);
        if amplitude > 0.0 {
            // The autocorrelation of s g is E[s s'] C_g: divide the amplitude's out.
            let k = amplitude_kernel();
            let s2 = amplitude * amplitude;
            for ly in 0..SIDE {
                for lx in 0..SIDE {
                    let rho = amplitude_rho1(&k, ly.abs_diff(RADIUS))
                        * amplitude_rho1(&k, lx.abs_diff(RADIUS));
                    c[ly * SIDE + lx] /= (s2 * (rho - 1.0)).exp();
                }
            }
        }
        // Power spectrum on the periodic grid: P(k) = sum over lags of C(l) cos(2 pi k . l / GRID) (C is even).
        let cos: Vec<f64> = (0..GRID)
            .map(|m| (2.0 * std::f64::consts::PI * m as f64 / GRID as f64).cos())
            .collect();
        let r = RADIUS as isize;
        let mut amp = vec![0.0; GRID * GRID];
        for ky in 0..GRID as isize {
            for kx in 0..GRID as isize {
                let mut p = 0.0;
                for ly in -r..=r {
                    for lx in -r..=r {
                        let cl = c[((ly + r) as usize) * SIDE + (lx + r) as usize];
                        let m = (ky * ly + kx * lx).rem_euclid(GRID as isize);
                        p += cl * cos[m as usize];
                    }
                }
                // Truncating C at RADIUS can leave small negative powers: the nearest valid spectrum clips them.
                amp[(ky as usize) * GRID + kx as usize] = p.max(0.0).sqrt();
            }
        }
        // K(l) = (1 / GRID^2) sum_k sqrt(P(k)) cos(2 pi k . l / GRID), on the kernel's window.
        let mut kernel = vec![0.0; SIDE * SIDE];
        for ly in -r..=r {
            for lx in -r..=r {
                let mut s = 0.0;
                for ky in 0..GRID as isize {
                    for kx in 0..GRID as isize {
                        let m = (ky * ly + kx * lx).rem_euclid(GRID as isize);
                        s += amp[(ky as usize) * GRID + kx as usize] * cos[m as usize];
                    }
                }
                kernel[((ly + r) as usize) * SIDE + (lx + r) as usize] = s / (GRID * GRID) as f64;
            }
        }
        // The window cuts the kernel's tail: rescale so the field's variance sum K^2 is the measured C(0).
        let var: f64 = kernel.iter().map(|k| k * k).sum();
        let c0 = c[RADIUS * SIDE + RADIUS];
        if var > 0.0 {
            let s = (c0 / var).sqrt();
            kernel.iter_mut().for_each(|k| *k *= s);
        }
        let mut detail = Detail {
            kernel,
            marginal: Vec::new(),
            amplitude,
        };
        // Quantile mapping from the synthesised field's law (measured on fields drawn from a fixed stream) to the
        // residuals'.
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let mut field: Vec<f64> = (0..MARGINAL_FIELDS)
            .flat_map(|_| detail.synthesise(&mut rng))
            .collect();
        let mut values: Vec<f64> = residuals.iter().flatten().copied().collect();
        let mut marginal = quantiles(&mut field);
        marginal.extend(quantiles(&mut values));
        detail.marginal = marginal;
        detail
    }

    /// The marginal transform of a synthesised value (identity without one): piecewise linear through the knots,
    /// extended linearly beyond the end knots.
    pub fn transform(&self, e: f64) -> f64 {
        if self.marginal.len() != 2 * KNOTS {
            return e;
        }
        let (x, y) = self.marginal.split_at(KNOTS);
        // The segment [x[i], x[i + 1]] holding e (the first or last one beyond the ends).
        let i = x.partition_point(|&k| k <= e).clamp(1, KNOTS - 1) - 1;
        let dx = x[i + 1] - x[i];
        if dx <= 0.0 {
            return y[i];
        }
        y[i] + (e - x[i]) * (y[i + 1] - y[i]) / dx
    }

    /// A `CROP_PX x CROP_PX` field drawn from `rng`: white Irwin-Hall noise on a grid [`RADIUS`] px wider on each
    /// side, convolved with the kernel; with an amplitude, multiplied by `exp(sigma a - sigma^2)`, `a` drawn next
    /// from the stream (white noise [`AMPLITUDE_RADIUS`] px wider on each side, smoothed by the separable
    /// Gaussian kernel); then the marginal transform.
    pub fn synthesise(&self, rng: &mut impl Rng) -> Vec<f64> {
        let wide = CROP_PX + 2 * RADIUS;
        let noise: Vec<f64> = (0..wide * wide).map(|_| irwin_hall(rng)).collect();
        let mut out = vec![0.0; CROP_PX * CROP_PX];
        for y in 0..CROP_PX {
            for x in 0..CROP_PX {
                let mut s = 0.0;
                for ky in 0..SIDE {
                    let row = &noise[(y + ky) * wide + x..(y + ky) * wide + x + SIDE];
                    let krow = &self.kernel[ky * SIDE..(ky + 1) * SIDE];
                    for (k, n) in krow.iter().zip(row) {
                        s += k * n;
                    }
                }
                out[y * CROP_PX + x] = s;
            }
        }
        if self.amplitude > 0.0 {
            let a = amplitude_field(rng);
            let s2 = self.amplitude * self.amplitude;
            for (o, a) in out.iter_mut().zip(&a) {
                *o *= crate::num::exp(self.amplitude * a - s2);
            }
        }
        out.iter_mut().for_each(|o| *o = self.transform(*o));
        out
    }

    /// Standard deviation of the synthesised field (`sqrt(sum K^2)`).
    pub fn std(&self) -> f64 {
        self.kernel.iter().map(|k| k * k).sum::<f64>().sqrt()
    }
}

/// The unit log-amplitude field `a`: white noise smoothed along rows, then along columns.
fn amplitude_field(rng: &mut impl Rng) -> Vec<f64> {
    let k = amplitude_kernel();
    let wide = CROP_PX + 2 * AMPLITUDE_RADIUS;
    let noise: Vec<f64> = (0..wide * wide).map(|_| irwin_hall(rng)).collect();
    // Rows: wide x CROP_PX.
    let mut rows = vec![0.0; wide * CROP_PX];
    for y in 0..wide {
        for x in 0..CROP_PX {
            rows[y * CROP_PX + x] = k
                .iter()
                .zip(&noise[y * wide + x..y * wide + x + k.len()])
                .map(|(a, b)| a * b)
                .sum();
        }
    }
    let mut out = vec![0.0; CROP_PX * CROP_PX];
    for y in 0..CROP_PX {
        for x in 0..CROP_PX {
            out[y * CROP_PX + x] = k
                .iter()
                .enumerate()
                .map(|(i, a)| a * rows[(y + i) * CROP_PX + x])
                .sum();
        }
    }
    out
}

/// The values' quantiles at probabilities `(i + 1/2) / KNOTS` (sorts `v`).
fn quantiles(v: &mut [f64]) -> Vec<f64> {
    v.sort_by(|a, b| a.total_cmp(b));
    (0..KNOTS)
        .map(|i| v[(((i as f64 + 0.5) / KNOTS as f64) * v.len() as f64) as usize])
        .collect()
}

/// Mean autocorrelation `C(ly, lx) = E[e(p) e(p + l)]` of the residual maps over all pixel pairs inside a map, for
/// `|ly|, |lx| <= RADIUS`, as a `SIDE x SIDE` array (row-major, centred).
pub fn autocorrelation(residuals: &[Vec<f64>]) -> Vec<f64> {
    let n = CROP_PX;
    let r = RADIUS as isize;
    let mut sum = vec![0.0; SIDE * SIDE];
    let mut count = vec![0usize; SIDE * SIDE];
    for e in residuals {
        for ly in -r..=r {
            for lx in -r..=r {
                let (y0, y1) = (
                    0.max(-ly) as usize,
                    (n as isize).min(n as isize - ly) as usize,
                );
                let (x0, x1) = (
                    0.max(-lx) as usize,
                    (n as isize).min(n as isize - lx) as usize,
                );
                let mut s = 0.0;
                for y in y0..y1 {
                    let a = &e[y * n + x0..y * n + x1];
                    let bs = ((y as isize + ly) as usize) * n;
                    let b = &e[(bs as isize + x0 as isize + lx) as usize
                        ..(bs as isize + x1 as isize + lx) as usize];
                    for (p, q) in a.iter().zip(b) {
                        s += p * q;
                    }
                }
                let i = ((ly + r) as usize) * SIDE + (lx + r) as usize;
                sum[i] += s;
                count[i] += (y1 - y0) * (x1 - x0);
            }
        }
    }
    sum.iter()
        .zip(&count)
        .map(|(s, c)| s / (*c).max(1) as f64)
        .collect()
}

#[cfg(test)]
mod tests;
