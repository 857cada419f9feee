//! The learned kinodynamic models in Rust: a `vertibench-kino-v1` file is read with its layout checked (a policy
//! file or a damaged one is refused naming what differs), and MPPI-6 rolling out a hand-built model (forward at the
//! nominal speed, turning with the steering command) drives real episodes to goals ahead and beside, the same at
//! every run.

use learned::kino::features::{FEATURES, LAYOUT, TARGETS};
use learned::kino::net::{CODE, CROP_META, HEAD_INPUTS};
use learned::kino::{KinoMppi, KinoMppiConfig, KinoNet, Rollout};
use learned::weights::{layout_metadata, untrained};
use safetensors::tensor::{Dtype, TensorView};
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::*;
use std::collections::HashMap;

fn metadata(members: usize) -> HashMap<String, String> {
    [
        ("format", LAYOUT.to_string()),
        ("features", FEATURES.join(",")),
        ("targets", TARGETS.join(",")),
        ("crop", CROP_META.to_string()),
        ("ensemble", members.to_string()),
        ("vehicle", "hmmwv".to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// A two-member model whose members agree: forward one nominal step, yaw 0.3 rad per unit of steering command, the
/// applied steering following the command; everything else zero. The tanh layers pass the command through at 1/100
/// of its size, undone by the output weights.
fn bicycle_like(meta: HashMap<String, String>) -> Vec<u8> {
    let h = 4;
    let zeros = |n: usize| vec![0f32; n];
    let steer = CODE
        + FEATURES
            .iter()
            .position(|f| *f == "action_steering")
            .unwrap();
    let mut tensors: Vec<(String, Vec<usize>, Vec<f32>)> = vec![
        ("enc.conv1.weight".into(), vec![8, 1, 3, 3], zeros(72)),
        ("enc.conv1.bias".into(), vec![8], zeros(8)),
        ("enc.conv2.weight".into(), vec![16, 8, 3, 3], zeros(16 * 72)),
        ("enc.conv2.bias".into(), vec![16], zeros(16)),
        ("enc.code.weight".into(), vec![CODE, 144], zeros(CODE * 144)),
        ("enc.code.bias".into(), vec![CODE], zeros(CODE)),
    ];
    for m in 0..2 {
        let mut fc1 = zeros(h * HEAD_INPUTS);
        fc1[steer] = 0.1;
        let mut fc2 = zeros(h * h);
        fc2[0] = 0.1;
        let mut out = zeros(TARGETS.len() * h);
        out[5 * h] = 300.0; // yaw
        out[6 * h] = 100.0; // steering
        let mut out_b = zeros(TARGETS.len());
        out_b[0] = 1.0; // forward: one nominal step
        for (n, s, v) in [
            ("fc1.weight", vec![h, HEAD_INPUTS], fc1),
            ("fc1.bias", vec![h], zeros(h)),
            ("fc2.weight", vec![h, h], fc2),
            ("fc2.bias", vec![h], zeros(h)),
            ("out.weight", vec![TARGETS.len(), h], out),
            ("out.bias", vec![TARGETS.len()], out_b),
        ] {
            tensors.push((format!("heads.{m}.{n}"), s, v));
        }
    }
    let bytes: Vec<(String, Vec<usize>, Vec<u8>)> = tensors
        .into_iter()
        .map(|(n, s, v)| (n, s, v.iter().flat_map(|x| x.to_le_bytes()).collect()))
        .collect();
    let views = bytes.iter().map(|(n, s, b)| {
        (
            n.as_str(),
            TensorView::new(Dtype::F32, s.clone(), b).unwrap(),
        )
    });
    safetensors::tensor::serialize(views, Some(meta)).unwrap()
}

#[test]
fn the_hand_built_model_predicts_what_it_was_built_to() {
    let mut net = KinoNet::from_bytes(&bicycle_like(metadata(2))).unwrap();
    assert_eq!(net.members(), 2);
    let mut vector = [0f32; FEATURES.len()];
    vector[9] = 0.5; // action_steering
    let mut out = [0f32; 14];
    net.predict(&vector, &[0.3; 256], &mut out);
    for m in 0..2 {
        let o = &out[m * 7..m * 7 + 7];
        assert_eq!(o[0], 1.0);
        assert!(
            (o[5] - 1.5).abs() < 2e-3 && (o[6] - 0.5).abs() < 1e-3,
            "{o:?}"
        );
        assert_eq!([o[1], o[2], o[3], o[4]], [0.0; 4]);
    }
}

#[test]
fn foreign_and_damaged_files_are_refused_naming_what_differs() {
    let refused = |bytes: &[u8], word: &str| {
        let e = KinoNet::from_bytes(bytes).unwrap_err().to_string();
        assert!(e.contains(word), "`{word}` not in: {e}");
    };
    refused(
        &untrained(1, 8, layout_metadata("rl", 20.0, "hmmwv")),
        "format",
    );
    let mut m = metadata(2);
    m.insert("targets".into(), "a,b".into());
    refused(&bicycle_like(m), "targets");
    refused(&bicycle_like(metadata(3)), "heads.2.fc1.weight");
    refused(&bicycle_like(metadata(0)), "ensemble");
    refused(b"not safetensors", "safetensors");
}

#[test]
fn mppi6_and_wmvct_with_a_hand_built_model_reach_goals_ahead_and_beside_deterministically() {
    let w = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    );
    let spec = vehicle_by_name("hmmwv").unwrap();
    let cfg = EpisodeConfig {
        max_time: 40.0,
        ..Default::default()
    };
    let net = KinoNet::from_bytes(&bicycle_like(metadata(2))).unwrap();
    for rollout in [Rollout::Learned, Rollout::Decomposed] {
        let small = KinoMppiConfig {
            samples: 16,
            horizon_steps: 6,
            rollout,
            ..Default::default()
        };
        reaches_goals(&w, &spec, &cfg, &net, small);
    }
}

fn reaches_goals(
    w: &World,
    spec: &sim_core::VehicleSpec,
    cfg: &EpisodeConfig,
    net: &KinoNet,
    small: KinoMppiConfig,
) {
    for goal in [[40.0, 0.0], [10.0, 40.0], [10.0, -40.0]] {
        let task = Task {
            world_id: 1,
            index: 0,
            start: [0.0, 0.0],
            goal,
            path: vec![[0.0, 0.0], goal],
        };
        let mut p = KinoMppi::new("mppi6", net.clone(), small);
        let r = sim_core::run_episode(w, &task, spec, &mut p, cfg);
        assert_eq!(
            r.outcome,
            Outcome::Success,
            "{small:?} goal {goal:?}: {r:?}"
        );
        assert!(p.decisions > 5 && p.predictions >= p.decisions * 16);
        let mut again = KinoMppi::new("mppi6", net.clone(), small);
        let r2 = sim_core::run_episode(w, &task, spec, &mut again, cfg);
        assert_eq!(r.metrics, r2.metrics, "deterministic");
    }
}
