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
}

impl Detail {
    /// Measures the autocorrelation of `residuals` (each `CROP_PX * CROP_PX`, row-major) at lags up to
    /// [`RADIUS`] and factorises it into a synthesis kernel whose output has the residuals' variance.
    pub fn fit(residuals: &[Vec<f64>]) -> Detail {
        let c = autocorrelation(residuals);
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
    /// side, convolved with the kernel.
    pub fn synthesise(&self, rng: &mut impl Rng) -> Vec<f64> {
        let wide = CROP_PX + 2 * RADIUS;
        let noise: Vec<f64> = (0..wide * wide)
            .map(|_| {
                (0..12)
                    .map(|_| rng.gen::<u32>() as f64 / 4_294_967_296.0)
                    .sum::<f64>()
                    - 6.0
            })
            .collect();
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
                out[y * CROP_PX + x] = self.transform(s);
            }
        }
        out
    }

    /// Standard deviation of the synthesised field (`sqrt(sum K^2)`).
    pub fn std(&self) -> f64 {
        self.kernel.iter().map(|k| k * k).sum::<f64>().sqrt()
    }
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
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A field synthesised from a fitted kernel has the autocorrelation it was fitted to (Wiener-Khinchin:
    /// the autocorrelation of white noise convolved with K is K * K). Reference: fields made by smoothing white
    /// noise with a 5 x 5 box, whose autocorrelation is the box's self-convolution (a pyramid); 5% tolerance on
    /// the lags that carry the variance, sampling error of 40 fields.
    #[test]
    fn a_fitted_field_reproduces_the_measured_autocorrelation() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let boxed = Detail {
            marginal: Vec::new(),
            kernel: {
                let mut k = vec![0.0; SIDE * SIDE];
                for dy in 0..5 {
                    for dx in 0..5 {
                        k[(RADIUS - 2 + dy) * SIDE + RADIUS - 2 + dx] = 0.2;
                    }
                }
                k
            },
        };
        let fields: Vec<Vec<f64>> = (0..40).map(|_| boxed.synthesise(&mut rng)).collect();
        let c = autocorrelation(&fields);
        // Box 5 x 5 of height 0.2: C(ly, lx) = 0.04 (5 - |ly|)(5 - |lx|) for |l| < 5, else 0.
        for (ly, lx) in [(0usize, 0usize), (0, 2), (1, 1), (3, 0)] {
            let expect = 0.04 * (5 - ly) as f64 * (5 - lx) as f64;
            let got = c[(RADIUS + ly) * SIDE + RADIUS + lx];
            assert!(
                (got / expect - 1.0).abs() < 0.05,
                "C({ly},{lx}) = {got}, expected {expect}"
            );
        }
        let fitted = Detail::fit(&fields);
        let refit: Vec<Vec<f64>> = (0..40).map(|_| fitted.synthesise(&mut rng)).collect();
        let c2 = autocorrelation(&refit);
        for (ly, lx) in [(0usize, 0usize), (0, 2), (1, 1), (3, 0)] {
            let a = c[(RADIUS + ly) * SIDE + RADIUS + lx];
            let b = c2[(RADIUS + ly) * SIDE + RADIUS + lx];
            assert!(
                (b / a - 1.0).abs() < 0.05,
                "lag ({ly},{lx}): fitted field {b}, data {a}"
            );
        }
        assert!((fitted.std() - c[RADIUS * SIDE + RADIUS].sqrt()).abs() < 1e-12);
    }

    /// The marginal transform gives the texture the residuals' law: fitted to heavy-tailed residuals (a smoothed
    /// field pushed through x + 0.1 x^3, kurtosis well above a Gaussian's 3), synthesised fields have their
    /// quantiles (within 5% at p05, p25, p75, p95) and kurtosis (within 15%), and the transform is monotone.
    #[test]
    fn the_texture_takes_the_residuals_marginal_law() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let mut k = vec![0.0; SIDE * SIDE];
        for dy in 0..3 {
            for dx in 0..3 {
                k[(RADIUS - 1 + dy) * SIDE + RADIUS - 1 + dx] = 1.0 / 3.0;
            }
        }
        let smooth = Detail {
            kernel: k,
            marginal: Vec::new(),
        };
        let residuals: Vec<Vec<f64>> = (0..30)
            .map(|_| {
                smooth
                    .synthesise(&mut rng)
                    .into_iter()
                    .map(|x| 0.05 * (x + 0.1 * x * x * x))
                    .collect()
            })
            .collect();
        let fitted = Detail::fit(&residuals);
        let fields: Vec<f64> = (0..30).flat_map(|_| fitted.synthesise(&mut rng)).collect();
        let data: Vec<f64> = residuals.iter().flatten().copied().collect();
        let kurtosis = |v: &[f64]| {
            let n = v.len() as f64;
            let m = v.iter().sum::<f64>() / n;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / n;
            v.iter().map(|x| (x - m).powi(4)).sum::<f64>() / n / (var * var)
        };
        let (kd, kf) = (kurtosis(&data), kurtosis(&fields));
        assert!(
            kd > 5.0,
            "the test's residuals are heavy-tailed: kurtosis {kd}"
        );
        assert!(
            (kf / kd - 1.0).abs() < 0.15,
            "kurtosis: texture {kf}, residuals {kd}"
        );
        let q = |v: &[f64], p: f64| {
            let mut s = v.to_vec();
            s.sort_by(|a, b| a.total_cmp(b));
            s[(p * s.len() as f64) as usize]
        };
        for p in [0.05, 0.25, 0.75, 0.95] {
            let (a, b) = (q(&fields, p), q(&data, p));
            assert!(
                (a / b - 1.0).abs() < 0.05,
                "quantile {p}: texture {a}, residuals {b}"
            );
        }
        let xs: Vec<f64> = (-400..=400).map(|i| i as f64 * 0.01).collect();
        assert!(xs
            .windows(2)
            .all(|w| fitted.transform(w[0]) <= fitted.transform(w[1])));
    }

    /// Irwin-Hall noise (12 uniforms - 6) has mean 0 and variance 1; the synthesised field's variance is sum K^2.
    #[test]
    fn synthesis_from_a_unit_kernel_is_unit_white_noise() {
        let mut k = vec![0.0; SIDE * SIDE];
        k[RADIUS * SIDE + RADIUS] = 1.0;
        let d = Detail {
            kernel: k,
            marginal: Vec::new(),
        };
        let f = d.synthesise(&mut ChaCha8Rng::seed_from_u64(1));
        let n = f.len() as f64;
        let mean = f.iter().sum::<f64>() / n;
        let var = f.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
        // 16384 samples: standard error of the mean 0.008, of the variance about 0.011 (Irwin-Hall kurtosis 2.9).
        assert!(mean.abs() < 0.03, "mean {mean}");
        assert!((var - 1.0).abs() < 0.04, "variance {var}");
        assert_eq!(f, d.synthesise(&mut ChaCha8Rng::seed_from_u64(1)));
    }
}
