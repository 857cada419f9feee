//! Tests of the detail model.

use super::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// A 3 x 3 box kernel of unit variance (nine taps of 1/3), no marginal transform, the given amplitude.
fn box3(amplitude: f64) -> Detail {
    let mut kernel = vec![0.0; SIDE * SIDE];
    for dy in 0..3 {
        for dx in 0..3 {
            kernel[(RADIUS - 1 + dy) * SIDE + RADIUS - 1 + dx] = 1.0 / 3.0;
        }
    }
    Detail {
        kernel,
        marginal: Vec::new(),
        amplitude,
    }
}

/// A field synthesised from a fitted kernel has the autocorrelation it was fitted to (Wiener-Khinchin:
/// the autocorrelation of white noise convolved with K is K * K). Reference: fields made by smoothing white
/// noise with a 5 x 5 box, whose autocorrelation is the box's self-convolution (a pyramid); 5% tolerance on
/// the lags that carry the variance, sampling error of 40 fields.
#[test]
fn a_fitted_field_reproduces_the_measured_autocorrelation() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let boxed = Detail {
        marginal: Vec::new(),
        amplitude: 0.0,
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
    let smooth = box3(0.0);
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

/// The amplitude makes a Gaussian scale mixture (Andrews and Mallows, J. R. Stat. Soc. B 36, 1974): fields
/// drawn with `sigma = 0.45` over a unit-variance 3 x 3 box kernel have kurtosis `3 exp(4 sigma^2)` (6.74;
/// within 12%: the amplitude varies over about 12 px, so 40 fields hold a few thousand independent amplitudes)
/// and slope ratio `E|grad e| / rms(grad e) = exp(-sigma^2 / 2) sqrt(pi) / 2` (0.806; the amplitude is smooth
/// against the texture, so `grad e` is close to `s grad g`, and `|grad g|` is Rayleigh; within 3%); fitting
/// the fields recovers `sigma` within 10%.
#[test]
fn the_amplitude_makes_a_gaussian_scale_mixture() {
    let sigma: f64 = 0.45;
    let mixture = box3(sigma);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let fields: Vec<Vec<f64>> = (0..40).map(|_| mixture.synthesise(&mut rng)).collect();
    let kurt = kurtosis(&fields);
    let want = 3.0 * (4.0 * sigma * sigma).exp();
    assert!(
        (kurt / want - 1.0).abs() < 0.12,
        "kurtosis {kurt}, theory {want}"
    );
    let n = CROP_PX;
    let (mut sum, mut sum2, mut count) = (0.0, 0.0, 0.0);
    for f in &fields {
        for y in 1..n - 1 {
            for x in 1..n - 1 {
                let gx = (f[y * n + x + 1] - f[y * n + x - 1]) / 2.0;
                let gy = (f[(y + 1) * n + x] - f[(y - 1) * n + x]) / 2.0;
                let g2 = gx * gx + gy * gy;
                sum += g2.sqrt();
                sum2 += g2;
                count += 1.0;
            }
        }
    }
    let ratio = sum / count / (sum2 / count).sqrt();
    let want = (-sigma * sigma / 2.0).exp() * std::f64::consts::PI.sqrt() / 2.0;
    assert!(
        (ratio / want - 1.0).abs() < 0.03,
        "slope ratio {ratio}, theory {want}"
    );
    let fitted = Detail::fit(&fields);
    assert!(
        (fitted.amplitude / sigma - 1.0).abs() < 0.10,
        "fitted amplitude {}",
        fitted.amplitude
    );
}

/// Irwin-Hall noise (12 uniforms - 6) has mean 0 and variance 1; the synthesised field's variance is sum K^2.
#[test]
fn synthesis_from_a_unit_kernel_is_unit_white_noise() {
    let mut k = vec![0.0; SIDE * SIDE];
    k[RADIUS * SIDE + RADIUS] = 1.0;
    let d = Detail {
        kernel: k,
        marginal: Vec::new(),
        amplitude: 0.0,
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
