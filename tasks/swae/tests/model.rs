//! The candle model, the plain-Rust decoder and the sliced-Wasserstein distance, on synthetic data (no shared
//! data needed).

use candle_core::{Device, Tensor};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use swae::data::Crop;
use swae::model::{self, Config, Swae};
use swae::train::{train, TrainOptions};
use swae::{Decoder, CROP_PX};

fn small() -> Config {
    Config {
        channels: vec![4, 4, 8, 8, 8],
        latent: 8,
    }
}

/// Smooth random terrain-like crops: a few Gaussian bumps.
fn synthetic(n: usize, seed: u64) -> Vec<Crop> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let bumps: Vec<(f64, f64, f64, f64)> = (0..3)
                .map(|_| {
                    (
                        rng.gen_range(20.0..108.0),
                        rng.gen_range(20.0..108.0),
                        rng.gen_range(10.0..30.0),
                        rng.gen_range(0.3..0.9),
                    )
                })
                .collect();
            let mut v = vec![0f32; CROP_PX * CROP_PX];
            for y in 0..CROP_PX {
                for x in 0..CROP_PX {
                    let mut h = -0.8;
                    for (cx, cy, r, a) in &bumps {
                        let d2 = (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2);
                        h += a * (-d2 / (2.0 * r * r)).exp();
                    }
                    v[y * CROP_PX + x] = h.clamp(-1.0, 1.0) as f32;
                }
            }
            Crop {
                path: format!("synthetic-{seed}").into(),
                values: v,
            }
        })
        .collect()
}

fn tmp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("swae-test-{}-{name}", std::process::id()))
}

fn candle_decode(model: &Swae, z: &[f64]) -> Vec<f64> {
    let zt = Tensor::from_vec(
        z.iter().map(|&v| v as f32).collect::<Vec<f32>>(),
        (1, z.len()),
        &Device::Cpu,
    )
    .unwrap();
    model
        .decode(&zt, false)
        .unwrap()
        .flatten_all()
        .unwrap()
        .to_vec1::<f32>()
        .unwrap()
        .into_iter()
        .map(|v| v as f64)
        .collect()
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn plain_rust_decoder_matches_candle_after_some_training() {
    // Train briefly so that BatchNorm statistics and weights are not at their initial values.
    let crops = synthetic(16, 1);
    let opts = TrainOptions {
        config: small(),
        epochs: 2,
        batch: 8,
        ..Default::default()
    };
    let (model, _) = train(&crops, &[], &opts, None, |_| {}).unwrap();
    let path = tmp("equiv.safetensors");
    model.save(&path).unwrap();
    let dec = Decoder::load(&path).unwrap();
    assert_eq!(dec.latent(), 8);
    assert_eq!(dec.encoder_channels(), vec![4, 4, 8, 8, 8]);
    let reloaded = Swae::load(&path).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..3 {
        let z: Vec<f64> = (0..8).map(|_| rng.gen_range(-2.5..2.5)).collect();
        let plain = dec.decode(&z).unwrap();
        assert_eq!(plain.len(), CROP_PX * CROP_PX);
        let d = max_diff(&plain, &candle_decode(&model, &z));
        assert!(d < 1e-4, "plain vs candle: max difference {d}");
        let d = max_diff(&plain, &candle_decode(&reloaded, &z));
        assert!(d < 1e-4, "plain vs reloaded candle: max difference {d}");
    }
    std::fs::remove_file(&path).unwrap();
}

#[test]
fn committed_weights_decode_like_candle() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("weights/swae-v1.safetensors");
    let model = Swae::load(&path).unwrap();
    let dec = Decoder::load(&path).unwrap();
    let src = swae::SwaeSource::committed().unwrap();
    for seed in [0u64, 1, 20_250_602] {
        let z = src.latent(seed);
        let d = max_diff(&dec.decode(&z).unwrap(), &candle_decode(&model, &z));
        assert!(d < 1e-4, "seed {seed}: max difference {d}");
    }
}

#[test]
fn training_on_small_synthetic_data_reduces_the_loss() {
    let crops = synthetic(32, 2);
    let opts = TrainOptions {
        config: small(),
        epochs: 12,
        batch: 8,
        lr: 3e-3,
        ..Default::default()
    };
    let (_, logs) = train(&crops, &crops[..8], &opts, None, |_| {}).unwrap();
    let (first, last) = (&logs[0], logs.last().unwrap());
    assert!(
        last.l2 < 0.5 * first.l2,
        "l2 {} -> {} did not halve",
        first.l2,
        last.l2
    );
    assert!(last.val_rmse.is_finite());
}

#[test]
fn sliced_wasserstein_is_near_zero_on_the_prior_and_large_when_shifted() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let a = model::normal_tensor(&mut rng, 512, 16).unwrap();
    let b = model::normal_tensor(&mut rng, 512, 16).unwrap();
    let theta = model::projections(&mut rng, 16, 200).unwrap();
    let same: f32 = model::sliced_wasserstein(&a, &b, &theta)
        .unwrap()
        .to_scalar()
        .unwrap();
    let shifted = (&b + 2.0).unwrap();
    let far: f32 = model::sliced_wasserstein(&a, &shifted, &theta)
        .unwrap()
        .to_scalar()
        .unwrap();
    assert!(same < 0.02, "prior vs prior: {same}");
    // A shift of 2 in every coordinate moves a unit projection by 2 u.1 on average: E[(2 sum u)^2] = 4.
    assert!(far > 2.0, "prior vs shifted prior: {far}");
    assert!(far > 100.0 * same);
}

#[test]
fn dihedral_augmentation_is_a_permutation() {
    let v: Vec<f32> = (0..16).map(|i| i as f32).collect();
    for k in 0..8 {
        let mut t = swae::data::dihedral(&v, 4, k);
        t.sort_by(|a, b| a.total_cmp(b));
        assert_eq!(t, v);
    }
    assert_eq!(swae::data::dihedral(&v, 4, 0), v);
}

#[test]
fn tanh_and_exp_are_accurate() {
    for i in -400..=400 {
        let x = i as f64 * 0.05;
        let (a, b) = (swae::decoder::tanh(x), x.tanh());
        assert!((a - b).abs() < 1e-14, "tanh({x}): {a} vs {b}");
        let (a, b) = (swae::decoder::exp(x), x.exp());
        assert!(((a - b) / b).abs() < 1e-14, "exp({x}): {a} vs {b}");
    }
}
