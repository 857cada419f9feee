//! Each noise model's statistics against its parameters, over many seeded draws. Tolerances are stated per test:
//! a sample mean or share within 4 standard errors of its parameter (a false failure about once in 16,000 runs;
//! the draws are seeded, so a run that passes always passes).

use contracts::TaskId;
use perception::actuation::Actuator;
use perception::obstacles::{detection_probability, Detector};
use perception::profile::{ActuationNoise, ObstacleNoise, SemanticsNoise, StateNoise};
use perception::rng::{stream, Channel, EpisodeKey};
use perception::semantics::{believed_patches, confusion, draw, nominal_surface};
use perception::state::StateEstimator;
use sim_core::planner::{Action, VehicleState};
use sim_core::world::{Heightmap, Obstacle, ObstacleKind, Semantic, Surface, World};

fn key(i: u32) -> EpisodeKey {
    EpisodeKey {
        task: TaskId::new(i / 10, i % 10),
        seed: 7,
        profile: 42,
    }
}

fn mean_std(x: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    let v = x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0);
    (m, v.sqrt())
}

fn at(t: f64, x: f64) -> VehicleState {
    VehicleState {
        time: t,
        position: [x, 0.0, 0.0],
        velocity: [1.0, 0.0, 0.0],
        speed: 1.0,
        ..Default::default()
    }
}

/// Drift grows as the profile says: exactly `drift_share` of the distance travelled, and the heading error
/// exactly `yaw_drift_deg_per_s` times the time (no white noise in this profile, so no tolerance beyond rounding).
#[test]
fn drift_grows_with_distance_and_time() {
    let cfg = StateNoise {
        drift_share: 0.01,
        yaw_drift_deg_per_s: 0.5,
        ..Default::default()
    };
    let mut est = StateEstimator::new(cfg, stream(&key(1), Channel::State), [0.0, 0.0]);
    for k in 0..=100 {
        let truth = at(k as f64 * 0.1, k as f64);
        let e = est.estimate(&truth);
        let yaw_err = e.yaw - truth.yaw;
        assert!((yaw_err.abs() - (0.5f64).to_radians() * truth.time).abs() < 1e-12);
        // The map frame turns about the start by the heading error, then slides 1 % of the path.
        let (s, c) = yaw_err.sin_cos();
        let turned = [c * truth.position[0], s * truth.position[0]];
        let slide = (e.position[0] - turned[0]).hypot(e.position[1] - turned[1]);
        assert!((slide - 0.01 * k as f64).abs() < 1e-9, "step {k}: {slide}");
    }
    assert!((est.distance() - 100.0).abs() < 1e-9);
}

/// White position noise has the profile's standard deviation and zero mean (20,000 draws: the mean within
/// 4 sigma / sqrt(n), the standard deviation within 4 %); per-episode velocity biases have the profile's spread
/// across 2,000 episodes (within 15 %).
#[test]
fn white_noise_and_biases_have_their_parameters() {
    let cfg = StateNoise {
        position_sigma: 0.3,
        ..Default::default()
    };
    let mut est = StateEstimator::new(cfg, stream(&key(2), Channel::State), [0.0, 0.0]);
    let errs: Vec<f64> = (0..20_000)
        .map(|k| est.estimate(&at(k as f64 * 0.1, 0.0)).position[1])
        .collect();
    let (m, s) = mean_std(&errs);
    assert!(m.abs() < 4.0 * 0.3 / (20_000f64).sqrt(), "mean {m}");
    assert!((s / 0.3 - 1.0).abs() < 0.04, "std {s}");

    let cfg = StateNoise {
        velocity_bias: 0.1,
        ..Default::default()
    };
    let biases: Vec<f64> = (0..2_000)
        .map(|i| {
            let mut est =
                StateEstimator::new(cfg.clone(), stream(&key(i), Channel::State), [0.0; 2]);
            est.estimate(&at(0.0, 0.0)).velocity[0] - 1.0
        })
        .collect();
    let (m, s) = mean_std(&biases);
    assert!(m.abs() < 4.0 * 0.1 / (2_000f64).sqrt(), "bias mean {m}");
    assert!((s / 0.1 - 1.0).abs() < 0.15, "bias spread {s}");
}

/// With latency 2 and no noise, the planner sees the state of two control steps ago (the first state until then).
#[test]
fn estimate_latency_in_control_steps() {
    let cfg = StateNoise {
        latency_steps: 2,
        ..Default::default()
    };
    let mut est = StateEstimator::new(cfg, stream(&key(3), Channel::State), [0.0, 0.0]);
    let seen: Vec<f64> = (0..6)
        .map(|k| est.estimate(&at(k as f64, k as f64)).position[0])
        .collect();
    assert_eq!(seen, [0.0, 0.0, 0.0, 1.0, 2.0, 3.0]);
}

/// Actuation: the vehicle holds still until the first command arrives `latency` steps late; a step command under a
/// first-order lag reaches `1 - exp(-n dt / tau)` after n steps (to rounding); gains over 4,000 episodes are
/// uniform in [1 - s, 1 + s] (mean within 4 standard errors, variance s^2/3 within 10 %).
#[test]
fn actuation_latency_lag_and_gain() {
    let cfg = ActuationNoise {
        latency_steps: 2,
        lag_s: 0.5,
        ..Default::default()
    };
    let mut act = Actuator::new(&cfg, stream(&key(4), Channel::Actuation), 0.5, 0.1);
    let full = Action {
        steering: 0.0,
        throttle: 1.0,
        brake: 0.0,
    };
    let applied: Vec<f64> = (0..8).map(|_| act.apply(full).throttle).collect();
    assert_eq!(&applied[..2], &[0.0, 0.0]);
    for (n, a) in applied[2..].iter().enumerate() {
        let want = 1.0 - (-(n as f64 + 1.0) * 0.1 / 0.5).exp();
        assert!((a - want).abs() < 1e-12, "step {n}: {a} vs {want}");
    }

    let s = 0.2;
    let cfg = ActuationNoise {
        throttle_gain_spread: s,
        steering_bias_deg: 2.0,
        ..Default::default()
    };
    let mut gains = Vec::new();
    for i in 0..4_000 {
        let act = Actuator::new(&cfg, stream(&key(i), Channel::Actuation), 0.5, 0.1);
        let (bias, gain) = act.bias_and_gain();
        assert!((bias.abs() - 2f64.to_radians() / 0.5).abs() < 1e-12);
        assert!((1.0 - s..=1.0 + s).contains(&gain));
        gains.push(gain);
    }
    let (m, sd) = mean_std(&gains);
    assert!(
        (m - 1.0).abs() < 4.0 * s / (3.0f64 * 4_000.0).sqrt(),
        "gain mean {m}"
    );
    assert!(
        (sd * sd / (s * s / 3.0) - 1.0).abs() < 0.1,
        "gain variance {}",
        sd * sd
    );
}

/// Semantics: over 50,000 draws of one class, the share read wrong is `error_rate` (within 4 standard errors) and
/// each of the nine wrong classes gets a ninth of it (within 4 standard errors); a given matrix is followed; the
/// planner is told the class's nominal surface.
#[test]
fn confusion_rates_over_many_draws() {
    let p = 0.3;
    let m = confusion(&SemanticsNoise {
        error_rate: p,
        confusion: None,
    });
    let mut rng = stream(&key(5), Channel::Semantics);
    let n = 50_000;
    let mut counts = [0usize; 10];
    for _ in 0..n {
        counts[draw(&m[Semantic::Mud.id() as usize], &mut rng).id() as usize] += 1;
    }
    let wrong = (n - counts[Semantic::Mud.id() as usize]) as f64 / n as f64;
    let se = (p * (1.0 - p) / n as f64).sqrt();
    assert!((wrong - p).abs() < 4.0 * se, "wrong share {wrong}");
    let q = p / 9.0;
    let se = (q * (1.0 - q) / n as f64).sqrt();
    for (j, c) in counts.iter().enumerate() {
        if j != Semantic::Mud.id() as usize {
            assert!(
                (*c as f64 / n as f64 - q).abs() < 4.0 * se,
                "class {j}: {c}"
            );
        }
    }

    // Deformable read as rigid, the dangerous error, from a matrix: snow is read as concrete half the time.
    let mut rows = vec![vec![0.0; 10]; 10];
    for (i, row) in rows.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    rows[9] = vec![0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.5];
    let m = confusion(&SemanticsNoise {
        error_rate: 0.0,
        confusion: Some(rows),
    });
    let snow = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Snow,
        Surface::Deformable {
            soil: Semantic::Snow.soil().unwrap(),
        },
    );
    let patches = believed_patches(&snow, &m, &mut rng);
    let concrete = patches
        .iter()
        .filter(|p| p.semantic == Semantic::Concrete)
        .count();
    let se = (0.25 / patches.len() as f64).sqrt();
    assert!((concrete as f64 / patches.len() as f64 - 0.5).abs() < 4.0 * se);
    for p in &patches {
        assert_eq!(p.surface, nominal_surface(p.semantic));
        assert!(p.semantic == Semantic::Concrete || p.semantic == Semantic::Snow);
    }
    assert_eq!(
        nominal_surface(Semantic::Concrete),
        Surface::Rigid { friction: 0.85 }
    );
}

/// Obstacles: the detection probability halves at the half range; the share detected in one scan at that range
/// over 20,000 episodes is p_max / 2 (within 4 standard errors); phantoms per scan average the Poisson mean.
#[test]
fn detection_probability_and_false_positives() {
    let cfg = ObstacleNoise {
        detection_max: 0.9,
        detection_half_range: 10.0,
        false_positives_per_update: 0.5,
    };
    assert!((detection_probability(&cfg, 10.0) - 0.45).abs() < 1e-12);
    assert!((detection_probability(&cfg, 0.0) - 0.9).abs() < 1e-12);
    let mut world = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.6 },
    );
    world.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: 10.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
        half_extents: [1.0, 1.0, 1.0],
    });
    let n = 20_000;
    let (mut detected, mut phantoms) = (0, 0);
    let mut out = Vec::new();
    for i in 0..n {
        let mut d = Detector::new(cfg.clone(), stream(&key(i), Channel::Obstacles), &world);
        d.scan(&world, [0.0, 0.0], 30.0, |_, _| true);
        detected += d.detected_count();
        out.clear();
        d.phantoms(&world, [0.0, 0.0], 30.0, &mut out);
        phantoms += out.len();
        assert!(out.iter().all(|o| o.x.hypot(o.y) <= 30.0));
    }
    let share = detected as f64 / n as f64;
    let se = (0.45 * 0.55 / n as f64).sqrt();
    assert!((share - 0.45).abs() < 4.0 * se, "detected share {share}");
    let mean = phantoms as f64 / n as f64;
    assert!(
        (mean - 0.5).abs() < 4.0 * (0.5 / n as f64).sqrt(),
        "phantoms {mean}"
    );
}
