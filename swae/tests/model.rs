//! The candle model, the plain-Rust decoder and the sliced-Wasserstein distance, on synthetic data (no shared
//! data needed).

use candle_core::{Device, Tensor};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use swae::data::Crop;
use swae::decoder::DecoderKind;
use swae::loss;
use swae::model::{Config, Swae};
use swae::train::{resume, sidecar, train, TrainOptions, TrainState};
use swae::{Decoder, CROP_PX};

fn small() -> Config {
    Config {
        channels: vec![4, 6, 6, 12, 12],
        latent: 8,
        decoder: DecoderKind::Upsample,
        linear_skip: false,
        detail: false,
        refiner: 0,
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
    for kind in [DecoderKind::Upsample, DecoderKind::Deconv] {
        decoders_agree(kind, false);
    }
    decoders_agree(DecoderKind::Upsample, true);
}

fn decoders_agree(kind: DecoderKind, skip: bool) {
    // Train briefly so that BatchNorm statistics and weights are not at their initial values.
    let crops = synthetic(16, 1);
    let opts = TrainOptions {
        config: Config {
            decoder: kind,
            linear_skip: skip,
            detail: skip,
            refiner: if skip { 4 } else { 0 },
            ..small()
        },
        epochs: 2,
        batch: 8,
        ..Default::default()
    };
    let (model, _) = train(&crops, &[], &opts, None, |_| {}).unwrap();
    let path = tmp(&format!("equiv-{kind:?}-{skip}.safetensors"));
    model.save(&path).unwrap();
    let dec = Decoder::load(&path).unwrap();
    assert_eq!(dec.latent(), 8);
    assert_eq!(dec.kind(), kind);
    assert_eq!(dec.has_linear_skip(), skip);
    assert_eq!(dec.detail().is_some(), skip);
    assert_eq!(dec.refiner_channels(), if skip { 4 } else { 0 });
    if let Some(d) = dec.detail() {
        // Fitted at the checkpoint: the residual field has the residuals' variance (not the zero it starts at).
        assert!(d.std() > 1e-3, "detail std {}", d.std());
        // A sample is the mean plus a field drawn from the stream: a pure function of the stream, in [-1, 1].
        let z: Vec<f64> = (0..8).map(|i| 0.3 * i as f64 - 1.0).collect();
        let a = dec.sample(&z, &mut ChaCha8Rng::seed_from_u64(9)).unwrap();
        let b = dec.sample(&z, &mut ChaCha8Rng::seed_from_u64(9)).unwrap();
        assert_eq!(a, b);
        assert!(a.iter().all(|v| (-1.0..=1.0).contains(v)));
        let mean = dec.decode(&z).unwrap();
        let spread = (a
            .iter()
            .zip(&mean)
            .map(|(x, m)| (x - m).powi(2))
            .sum::<f64>()
            / a.len() as f64)
            .sqrt();
        assert!(
            spread > 0.3 * d.std(),
            "sample - mean rms {spread}, field std {}",
            d.std()
        );
        assert_eq!(
            d.marginal.len(),
            2 * swae::detail::KNOTS,
            "the marginal transform was fitted"
        );
        // A file written before the marginal transform (no `detail.marginal`) still loads, without a transform.
        let mut tensors = candle_core::safetensors::load(&path, &Device::Cpu).unwrap();
        assert!(tensors.remove("detail.marginal").is_some());
        let old = tmp("before-marginal.safetensors");
        candle_core::safetensors::save(&tensors, &old).unwrap();
        assert!(Decoder::load(&old)
            .unwrap()
            .detail()
            .unwrap()
            .marginal
            .is_empty());
        assert_eq!(Swae::load(&old).unwrap().config, opts.config);
        std::fs::remove_file(&old).unwrap();
    }
    assert_eq!(dec.encoder_channels(), vec![4, 6, 6, 12, 12]);
    let reloaded = Swae::load(&path).unwrap();
    assert_eq!(reloaded.config, opts.config);
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..3 {
        let z: Vec<f64> = (0..8).map(|_| rng.gen_range(-2.5..2.5)).collect();
        let plain = dec.decode(&z).unwrap();
        assert_eq!(plain.len(), CROP_PX * CROP_PX);
        let d = max_diff(&plain, &candle_decode(&model, &z));
        assert!(d < 1e-4, "{kind:?}: plain vs candle: max difference {d}");
        let d = max_diff(&plain, &candle_decode(&reloaded, &z));
        assert!(d < 1e-4, "plain vs reloaded candle: max difference {d}");
    }
    std::fs::remove_file(&path).unwrap();
}

/// A model with a linear skip starts as the PCA it is set from: its reconstructions equal the PCA's (the conv
/// paths' last layers are zero), so training starts from the PCA's error.
#[test]
fn a_linear_skip_model_starts_as_its_pca() {
    let crops = synthetic(24, 5);
    let config = Config {
        linear_skip: true,
        ..small()
    };
    let model = Swae::new(config, &mut ChaCha8Rng::seed_from_u64(1)).unwrap();
    let pca = swae::eval::Pca::fit(&crops, 8).unwrap();
    model.init_linear_skip(&pca).unwrap();
    let held_out = synthetic(4, 6);
    let rec = swae::train::reconstruct(&model, &held_out).unwrap();
    for (c, r) in held_out.iter().zip(&rec) {
        let p = pca.reconstruct(&c.values);
        let r: Vec<f64> = r.iter().map(|&v| v as f64).collect();
        let d = max_diff(&r, &p);
        assert!(d < 1e-4, "skip model vs PCA: max difference {d}");
    }
    // And a model without the skip refuses to be set from a PCA.
    let plain = Swae::new(small(), &mut ChaCha8Rng::seed_from_u64(1)).unwrap();
    assert!(plain.init_linear_skip(&pca).is_err());
}

/// `freeze_conv` trains the refiner alone: the conv paths' weights are those the model started with, the
/// refiner's have moved; without a linear skip the option is refused with the reason.
#[test]
fn freezing_the_conv_paths_trains_only_the_refiner() {
    let crops = synthetic(16, 7);
    let config = Config {
        linear_skip: true,
        refiner: 4,
        ..small()
    };
    let opts = TrainOptions {
        config: config.clone(),
        freeze_conv: true,
        epochs: 1,
        batch: 8,
        ..Default::default()
    };
    let (model, _) = train(&crops, &[], &opts, None, |_| {}).unwrap();
    let start = Swae::new(config.clone(), &mut ChaCha8Rng::seed_from_u64(opts.seed)).unwrap();
    start
        .init_linear_skip(&swae::eval::Pca::fit(&crops, 8).unwrap())
        .unwrap();
    let values = |m: &Swae, name: &str| -> Vec<f32> {
        m.varmap.data().lock().unwrap()[name]
            .as_tensor()
            .flatten_all()
            .unwrap()
            .to_vec1()
            .unwrap()
    };
    for name in [
        "enc.conv0.weight",
        "enc.fc.weight",
        "dec.fc.weight",
        "dec.up4.weight",
    ] {
        assert_eq!(values(&model, name), values(&start, name), "{name} moved");
    }
    assert_ne!(
        values(&model, "ref.conv2.weight"),
        values(&start, "ref.conv2.weight"),
        "the refiner did not train"
    );
    let err = train(
        &crops,
        &[],
        &TrainOptions {
            config: small(),
            freeze_conv: true,
            ..opts
        },
        None,
        |_| {},
    )
    .err()
    .expect("freeze_conv without a linear skip refused")
    .to_string();
    assert!(err.contains("linear_skip"), "{err}");
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
    let a = loss::normal_tensor(&mut rng, 512, 16).unwrap();
    let b = loss::normal_tensor(&mut rng, 512, 16).unwrap();
    let theta = loss::projections(&mut rng, 16, 200).unwrap();
    let same: f32 = loss::sliced_wasserstein(&a, &b, &theta)
        .unwrap()
        .to_scalar()
        .unwrap();
    let shifted = (&b + 2.0).unwrap();
    let far: f32 = loss::sliced_wasserstein(&a, &shifted, &theta)
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

#[test]
fn gradient_domain_terms_are_exact_on_polynomials() {
    // h = a x^2 + c y: forward differences a (2x + 1) along x and c along y; the five-point Laplacian of a
    // quadratic is exact, 2a; the central-difference slope at (x, y) is |(2 a x, c)|.
    let (a, c, n) = (0.01f32, 0.03f32, 8usize);
    let v: Vec<f32> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            a * x * x + c * y
        })
        .collect();
    let t = Tensor::from_vec(v, (1, 1, n, n), &Device::Cpu).unwrap();
    let (dx, dy) = loss::forward_differences(&t).unwrap();
    let dx: Vec<Vec<f32>> = dx
        .squeeze(0)
        .unwrap()
        .squeeze(0)
        .unwrap()
        .to_vec2()
        .unwrap();
    assert!((dx[3][4] - a * 9.0).abs() < 1e-6, "{}", dx[3][4]);
    let dy: Vec<f32> = dy.flatten_all().unwrap().to_vec1().unwrap();
    assert!(dy.iter().all(|d| (d - c).abs() < 1e-6));
    let lap: Vec<f32> = loss::laplacian(&t)
        .unwrap()
        .flatten_all()
        .unwrap()
        .to_vec1()
        .unwrap();
    assert_eq!(lap.len(), (n - 2) * (n - 2));
    assert!(lap.iter().all(|l| (l - 2.0 * a).abs() < 1e-5), "{lap:?}");
    let s: Vec<Vec<f32>> = loss::slope_magnitudes(&t).unwrap().to_vec2().unwrap();
    // Row-major interior: index 0 is (x, y) = (1, 1).
    let want = ((2.0 * a).powi(2) + c * c).sqrt();
    assert!((s[0][0] - want).abs() < 1e-4, "{} vs {want}", s[0][0]);
}

#[test]
fn training_resumes_from_its_checkpoint_where_it_stopped() {
    // Two epochs, then a resume to four, against four epochs in one go: the resumed run continues the schedule,
    // the optimiser's moments and the random stream (same shuffles, augmentation and prior samples), so its
    // losses follow the unbroken run's (to float rounding of candle's threaded kernels).
    let crops = synthetic(24, 4);
    let opts = TrainOptions {
        config: small(),
        epochs: 4,
        batch: 8,
        lr: 3e-3,
        session_epochs: 2,
        ..Default::default()
    };
    let out = tmp("resume.safetensors");
    let (_, first) = train(&crops, &crops[..8], &opts, Some(&out), |_| {}).unwrap();
    assert_eq!(first.len(), 2);
    let (_, rest) = resume(&crops, &crops[..8], &out, None, 0.0, |_| {}).unwrap();
    assert_eq!(rest.iter().map(|l| l.epoch).collect::<Vec<_>>(), [3, 4]);
    let state: TrainState =
        serde_json::from_str(&std::fs::read_to_string(sidecar(&out, "state.json")).unwrap())
            .unwrap();
    assert_eq!((state.epochs_done, state.adam_step), (4, 12));
    let log = std::fs::read_to_string(sidecar(&out, "train.log")).unwrap();
    assert_eq!(log.lines().filter(|l| l.starts_with("epoch")).count(), 4);
    let unbroken = TrainOptions {
        session_epochs: 0,
        ..opts.clone()
    };
    let (_, whole) = train(&crops, &crops[..8], &unbroken, None, |_| {}).unwrap();
    for (a, b) in whole[2..].iter().zip(&rest) {
        assert!(
            (a.l2 - b.l2).abs() <= 1e-3 * a.l2.max(1e-6),
            "epoch {}: unbroken l2 {} vs resumed {}",
            a.epoch,
            a.l2,
            b.l2
        );
    }
    // Weights that do not match the state (a save interrupted between the files) are refused.
    std::fs::write(&out, b"not the weights").unwrap();
    let err = resume(&crops, &[], &out, None, 0.0, |_| {})
        .err()
        .expect("mismatched checkpoint refused")
        .to_string();
    assert!(err.contains("interrupted while saving"), "{err}");
    for suffix in [
        "safetensors",
        "optim.safetensors",
        "state.json",
        "train.log",
    ] {
        let _ = std::fs::remove_file(sidecar(&out, suffix));
    }
}

#[test]
fn the_default_decoder_matches_candle_where_candle_conv2d_would_not() {
    // The default upsampling decoder convolves 32 channels on 32 x 32 px, where candle 0.9.2's conv2d is wrong
    // (huggingface/candle issue 3404); the model's own im2col conv must agree with the plain-Rust decoder there.
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let model = Swae::new(Config::default(), &mut rng).unwrap();
    let path = tmp("default-upsample.safetensors");
    model.save(&path).unwrap();
    let dec = Decoder::load(&path).unwrap();
    let z: Vec<f64> = (0..64).map(|_| rng.gen_range(-2.5..2.5)).collect();
    let d = max_diff(&dec.decode(&z).unwrap(), &candle_decode(&model, &z));
    assert!(d < 1e-4, "plain vs candle: max difference {d}");
    std::fs::remove_file(&path).unwrap();
    // An encoder that would meet the bug is refused with the reason.
    let err = Swae::new(
        Config {
            channels: vec![4, 4, 8, 8, 8],
            ..small()
        },
        &mut rng,
    )
    .err()
    .expect("8 channels on 8 px refused")
    .to_string();
    assert!(err.contains("8 channels on 8 px"), "{err}");
}

#[test]
fn decoder_names_are_the_training_states() {
    for kind in [DecoderKind::Deconv, DecoderKind::Upsample] {
        let name = serde_json::to_value(kind).unwrap();
        assert_eq!(name.as_str().unwrap().parse::<DecoderKind>(), Ok(kind));
    }
    let err = "conv".parse::<DecoderKind>().unwrap_err();
    assert!(err.contains("upsample"), "{err}");
}
