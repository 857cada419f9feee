//! The Rust inference of `vertibench-policy-v1` weights files: the actor against a plain reference, the refusals of
//! files of another layout, and a hand-built policy (steer toward the goal, constant throttle) driving real episodes
//! through `LearnedPlanner`, which checks the features' and the actions' sign conventions end to end.

use learned::features::{CROP_CHANNELS, CROP_SIZE, FEATURES};
use learned::net::ACTOR_INPUTS;
use learned::weights::{layout_metadata, untrained};
use learned::{LearnedPlanner, PolicyNet, WeightsError};
use safetensors::tensor::{Dtype, TensorView};
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::planner::Planner;
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::*;
use std::collections::HashMap;

fn read(bytes: &[u8]) -> HashMap<String, (Vec<usize>, Vec<f64>)> {
    let st = safetensors::SafeTensors::deserialize(bytes).unwrap();
    st.tensors()
        .into_iter()
        .map(|(n, t)| {
            let v = t
                .data()
                .chunks_exact(4)
                .map(|b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))
                .collect();
            (n, (t.shape().to_vec(), v))
        })
        .collect()
}

/// The actor in f64 with explicit 4-D indexing, written apart from the crate's.
fn reference(
    t: &HashMap<String, (Vec<usize>, Vec<f64>)>,
    vector: &[f32],
    crop: &[f32],
) -> [f64; 2] {
    let conv =
        |name: &str, input: &[f64], c_in: usize, side: usize, k: usize| -> (Vec<f64>, usize) {
            let (ws, w) = &t[&format!("{name}.weight")];
            let b = &t[&format!("{name}.bias")].1;
            let out_side = (side - k) / 2 + 1;
            let mut out = vec![0.0; ws[0] * out_side * out_side];
            for f in 0..ws[0] {
                for y in 0..out_side {
                    for x in 0..out_side {
                        let mut acc = b[f];
                        for c in 0..c_in {
                            for ky in 0..k {
                                for kx in 0..k {
                                    acc += w[((f * c_in + c) * k + ky) * k + kx]
                                        * input[(c * side + 2 * y + ky) * side + 2 * x + kx];
                                }
                            }
                        }
                        out[(f * out_side + y) * out_side + x] = acc.max(0.0);
                    }
                }
            }
            (out, out_side)
        };
    let crop: Vec<f64> = crop.iter().map(|&v| f64::from(v)).collect();
    let (a1, s1) = conv("enc.conv1", &crop, CROP_CHANNELS, CROP_SIZE, 4);
    let (mut a2, _) = conv("enc.conv2", &a1, 8, s1, 3);
    a2.extend(vector.iter().map(|&v| f64::from(v)));
    let dense = |name: &str, x: &[f64], tanh: bool| -> Vec<f64> {
        let (ws, w) = &t[&format!("{name}.weight")];
        let b = &t[&format!("{name}.bias")].1;
        (0..ws[0])
            .map(|o| {
                let s = b[o] + (0..ws[1]).map(|i| w[o * ws[1] + i] * x[i]).sum::<f64>();
                if tanh {
                    s.tanh()
                } else {
                    s
                }
            })
            .collect()
    };
    let h = dense("pi.fc2", &dense("pi.fc1", &a2, true), true);
    let m = dense("pi.mean", &h, false);
    [m[0].clamp(-1.0, 1.0), m[1].clamp(-1.0, 1.0)]
}

fn inputs(seed: u32) -> ([f32; FEATURES.len()], Vec<f32>) {
    let mut x = seed.wrapping_mul(2_654_435_761).wrapping_add(1);
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        (x as f32 / u32::MAX as f32) * 4.0 - 2.0
    };
    let vector = std::array::from_fn(|_| next());
    let crop = (0..CROP_CHANNELS * CROP_SIZE * CROP_SIZE)
        .map(|_| next())
        .collect();
    (vector, crop)
}

#[test]
fn the_actor_matches_a_plain_reference_and_is_deterministic() {
    let bytes = untrained(3, 64, layout_metadata("rl", 20.0, "hmmwv"));
    let tensors = read(&bytes);
    let mut net = PolicyNet::from_bytes(&bytes).expect("a valid file");
    assert_eq!(net.hidden(), 64);
    assert_eq!(net.metadata()["name"], "rl");
    let mut again = net.clone();
    for seed in 0..20 {
        let (v, c) = inputs(seed);
        let a = net.act(&v, &c);
        let r = reference(&tensors, &v, &c);
        for k in 0..2 {
            assert!(
                (f64::from(a[k]) - r[k]).abs() < 1e-5,
                "seed {seed}: {a:?} vs {r:?}"
            );
        }
        assert_eq!(a, again.act(&v, &c));
    }
}

fn expect_refused(bytes: &[u8], words: &[&str]) {
    let e = PolicyNet::from_bytes(bytes)
        .expect_err("refused")
        .to_string();
    for w in words {
        assert!(e.contains(w), "`{e}` does not say `{w}`");
    }
}

#[test]
fn files_of_another_layout_are_refused_saying_what_differs() {
    let meta = || layout_metadata("rl", 20.0, "hmmwv");
    let mut m = meta();
    m.insert("format".into(), "vertibench-policy-v0".into());
    expect_refused(
        &untrained(1, 8, m),
        &["format", "vertibench-policy-v0", "vertibench-policy-v1"],
    );
    let mut m = meta();
    m.insert("features".into(), "goal_cos,goal_sin".into());
    expect_refused(
        &untrained(1, 8, m),
        &["features", "goal_cos,goal_sin`", "throttle_1"],
    );
    let mut m = meta();
    m.remove("crop");
    expect_refused(&untrained(1, 8, m), &["crop", "missing", "2x16x16"]);
    let mut m = meta();
    m.insert("control_rate_hz".into(), "fast".into());
    expect_refused(&untrained(1, 8, m), &["control_rate_hz", "fast"]);
    expect_refused(b"not a weights file at all", &["not a safetensors file"]);
    // A tensor of the wrong shape, and one missing.
    let w = vec![0u8; 4 * 7];
    let view = TensorView::new(Dtype::F32, vec![7], &w).unwrap();
    let bytes = safetensors::tensor::serialize([("pi.fc1.weight", view)], Some(meta())).unwrap();
    let e = PolicyNet::from_bytes(&bytes).expect_err("refused");
    assert!(matches!(e, WeightsError::Tensor { .. }), "{e}");
}

/// A policy that steers toward the goal (steering = tanh-saturated goal bearing's sine) at a constant throttle: its
/// only non-zero weights read feature `goal_sin`, and the crop is ignored.
fn homing_policy() -> Vec<u8> {
    let h = 4;
    let zeros = |n: usize| vec![0f32; n];
    let mut fc1 = zeros(h * ACTOR_INPUTS);
    let code = ACTOR_INPUTS - FEATURES.len();
    let sin = FEATURES.iter().position(|f| *f == "goal_sin").unwrap();
    fc1[code + sin] = 3.0; // h1[0] = tanh(3 goal_sin)
    let mut fc1_b = zeros(h);
    fc1_b[1] = 1.0; // h1[1] = tanh(1)
    let mut fc2 = zeros(h * h);
    fc2[0] = 2.0; // h2[0] = tanh(2 h1[0])
    fc2[h + 1] = 1.0; // h2[1] = tanh(h1[1])
    let mut mean = zeros(2 * h);
    mean[0] = 2.0; // steering = 2 h2[0]
    mean[h + 1] = 0.9; // throttle = 0.9 tanh(tanh(1)) ~ 0.58
    let tensors: Vec<(&str, Vec<usize>, Vec<f32>)> = vec![
        ("enc.conv1.weight", vec![8, 2, 4, 4], zeros(8 * 2 * 16)),
        ("enc.conv1.bias", vec![8], zeros(8)),
        ("enc.conv2.weight", vec![16, 8, 3, 3], zeros(16 * 8 * 9)),
        ("enc.conv2.bias", vec![16], zeros(16)),
        ("pi.fc1.weight", vec![h, ACTOR_INPUTS], fc1),
        ("pi.fc1.bias", vec![h], fc1_b),
        ("pi.fc2.weight", vec![h, h], fc2),
        ("pi.fc2.bias", vec![h], zeros(h)),
        ("pi.mean.weight", vec![2, h], mean),
        ("pi.mean.bias", vec![2], zeros(2)),
    ];
    let bytes: Vec<(String, Vec<usize>, Vec<u8>)> = tensors
        .into_iter()
        .map(|(n, s, v)| {
            (
                n.to_string(),
                s,
                v.iter().flat_map(|x| x.to_le_bytes()).collect(),
            )
        })
        .collect();
    let views = bytes.iter().map(|(n, s, b)| {
        (
            n.as_str(),
            TensorView::new(Dtype::F32, s.clone(), b).unwrap(),
        )
    });
    safetensors::tensor::serialize(views, Some(layout_metadata("homing", 20.0, "hmmwv"))).unwrap()
}

fn straight(goal: [f64; 2]) -> Task {
    Task {
        world_id: 1,
        index: 0,
        start: [0.0, 0.0],
        goal,
        path: vec![[0.0, 0.0], goal],
    }
}

fn flat() -> World {
    World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    )
}

#[test]
fn a_hand_built_homing_policy_reaches_goals_ahead_beside_and_behind() {
    let w = flat();
    let spec = vehicle_by_name("hmmwv").unwrap();
    let cfg = EpisodeConfig {
        max_time: 60.0,
        ..Default::default()
    };
    let net = PolicyNet::from_bytes(&homing_policy()).unwrap();
    for goal in [[40.0, 0.0], [0.0, 40.0], [0.0, -40.0], [-35.0, 10.0]] {
        let task = straight(goal);
        let mut p = LearnedPlanner::new("homing", net.clone());
        assert_eq!(p.control_rate_hz(), 20.0);
        let r = sim_core::run_episode(&w, &task, &spec, &mut p, &cfg);
        assert_eq!(r.outcome, Outcome::Success, "goal {goal:?}: {r:?}");
        let again = sim_core::run_episode(
            &w,
            &task,
            &spec,
            &mut LearnedPlanner::new("homing", net.clone()),
            &cfg,
        );
        assert_eq!(r.metrics, again.metrics, "deterministic");
    }
}

#[test]
fn a_policy_for_another_vehicle_ends_its_episode_with_a_planner_error() {
    let w = flat();
    let spec = vehicle_by_name("gator").unwrap();
    let task = straight([10.0, 0.0]);
    let mut p = LearnedPlanner::new("homing", PolicyNet::from_bytes(&homing_policy()).unwrap());
    let r = sim_core::run_episode(&w, &task, &spec, &mut p, &EpisodeConfig::default());
    assert_ne!(r.outcome, Outcome::Success);
    assert!(r.detail.contains("trained for the hmmwv"), "{r:?}");
}
