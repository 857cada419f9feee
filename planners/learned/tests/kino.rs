//! The learned kinodynamic models in Rust: `vertibench-kino-v1` and `vertibench-tal-v1` files are read with their
//! layout checked (a policy file, the other layout or a damaged one is refused naming what differs), the
//! terrain-attentive model's gate makes its prediction depend on the map and on where the pose is over it, and MPPI-6
//! rolling out a hand-built model of either layout (forward at the nominal speed, turning with the steering command)
//! drives real episodes to goals ahead and beside, the same at every run. The traversability estimator
//! (`vertibench-tnt-v1`) reads the map at the anchor and is looked up at poses in that map's frame: a hand-built one
//! that flags raised ground finds a block where it stands, whichever way the anchor faces, and `tnt`'s MPPI with it
//! still reaches goals.

use learned::kino::features::{FEATURES, LAYOUT, TARGETS};
use learned::kino::net::{CODE, CROP_META, HEAD_INPUTS};
use learned::kino::tal::{
    map_features, offset_features, EMBED, GATE_HIDDEN, MAP_META, MAP_SIZE, OFFSETS, TAL_LAYOUT,
};
use learned::kino::tnt::{CHANNELS, CHANNEL_WEIGHTS, GRID_META, HEADINGS, TNT_LAYOUT};
use learned::kino::{Dynamics, KinoMppi, KinoMppiConfig, KinoNet, Rollout, TalNet, TravNet};
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

fn tal_metadata(members: usize) -> HashMap<String, String> {
    let mut m = metadata(members);
    m.remove("crop");
    m.insert("format".into(), TAL_LAYOUT.into());
    m.insert("offsets".into(), OFFSETS.join(","));
    m.insert("map".into(), MAP_META.into());
    m
}

type Tensors = Vec<(String, Vec<usize>, Vec<f32>)>;

/// The terrain-attentive layers: encoder, gate and fusion, weights of the order of `w` (the gate's 100 `w`); zero
/// leaves the code at zero.
fn tal_layers(w: f32) -> Tensors {
    let v = |n: usize| vec![w; n];
    vec![
        ("enc.conv1.weight".into(), vec![8, 1, 3, 3], v(72)),
        ("enc.conv1.bias".into(), vec![8], v(8)),
        ("enc.conv2.weight".into(), vec![16, 8, 3, 3], v(16 * 72)),
        ("enc.conv2.bias".into(), vec![16], v(16)),
        (
            "att.gate1.weight".into(),
            vec![GATE_HIDDEN, OFFSETS.len()],
            (0..GATE_HIDDEN * OFFSETS.len())
                .map(|i| 100.0 * w * ((i % 3) as f32 - 1.0))
                .collect(),
        ),
        ("att.gate1.bias".into(), vec![GATE_HIDDEN], v(GATE_HIDDEN)),
        (
            "att.gate2.weight".into(),
            vec![EMBED, GATE_HIDDEN],
            (0..EMBED * GATE_HIDDEN)
                .map(|i| 100.0 * w * ((i % 7) as f32 - 3.0))
                .collect(),
        ),
        ("att.gate2.bias".into(), vec![EMBED], v(EMBED)),
        (
            "att.fuse.weight".into(),
            vec![CODE, EMBED],
            (0..CODE * EMBED)
                .map(|i| w * ((i % 5) as f32 - 2.0))
                .collect(),
        ),
        ("att.fuse.bias".into(), vec![CODE], v(CODE)),
    ]
}

/// A two-member model whose members agree: forward one nominal step, yaw 0.3 rad per unit of steering command, the
/// applied steering following the command; everything else zero. The tanh layers pass the command through at 1/100
/// of its size, undone by the output weights.
fn bicycle_like(meta: HashMap<String, String>) -> Vec<u8> {
    let zeros = |n: usize| vec![0f32; n];
    let layers: Tensors = if meta.get("format").map(String::as_str) == Some(TAL_LAYOUT) {
        tal_layers(0.0)
    } else {
        vec![
            ("enc.conv1.weight".into(), vec![8, 1, 3, 3], zeros(72)),
            ("enc.conv1.bias".into(), vec![8], zeros(8)),
            ("enc.conv2.weight".into(), vec![16, 8, 3, 3], zeros(16 * 72)),
            ("enc.conv2.bias".into(), vec![16], zeros(16)),
            ("enc.code.weight".into(), vec![CODE, 144], zeros(CODE * 144)),
            ("enc.code.bias".into(), vec![CODE], zeros(CODE)),
        ]
    };
    serialize(layers, 1.0, meta)
}

/// `layers` and two agreeing heads: the bicycle-like heads, plus `code_weight` times the code's first entry on the
/// change of height (zero in the bicycle, whose code is zero anyway).
fn serialize(mut tensors: Tensors, code_weight: f32, meta: HashMap<String, String>) -> Vec<u8> {
    let h = 4;
    let zeros = |n: usize| vec![0f32; n];
    let steer = CODE
        + FEATURES
            .iter()
            .position(|f| *f == "action_steering")
            .unwrap();
    for m in 0..2 {
        let mut fc1 = zeros(h * HEAD_INPUTS);
        fc1[steer] = 0.1;
        fc1[HEAD_INPUTS] = 0.01 * code_weight; // hidden unit 1 reads the code's first entry
        let mut fc2 = zeros(h * h);
        fc2[0] = 0.1;
        fc2[h + 1] = 0.1;
        let mut out = zeros(TARGETS.len() * h);
        out[2 * h + 1] = 1000.0; // up, from hidden unit 1
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
    to_bytes(tensors, meta)
}

/// A safetensors file of f32 `tensors` with `meta`.
fn to_bytes(tensors: Tensors, meta: HashMap<String, String>) -> Vec<u8> {
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
fn the_attentive_model_reads_both_layouts_apart_and_attends_to_the_map_where_the_pose_is() {
    // The layout decides the model; each reader refuses the other's file by its format.
    let tal = bicycle_like(tal_metadata(2));
    assert!(matches!(
        Dynamics::from_bytes(&tal),
        Ok(Dynamics::Attention(_))
    ));
    let crop = bicycle_like(metadata(2));
    assert!(matches!(Dynamics::from_bytes(&crop), Ok(Dynamics::Crop(_))));
    assert!(TalNet::from_bytes(&crop)
        .unwrap_err()
        .to_string()
        .contains("format"));
    let mut m = tal_metadata(2);
    m.insert("map".into(), "1x16x16".into());
    assert!(TalNet::from_bytes(&bicycle_like(m))
        .unwrap_err()
        .to_string()
        .contains("map"));

    // Non-zero attention layers: the change of height follows the code, which depends on the map and the offset.
    let mut net = TalNet::from_bytes(&serialize(tal_layers(0.01), 1.0, tal_metadata(2))).unwrap();
    let ramp = World::uniform(
        Heightmap::from_fn(0.5, |x, y| 0.2 * x + 0.05 * y * y.signum()),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    );
    let vector = [0f32; FEATURES.len()];
    let anchor = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    let up = |net: &mut TalNet, world: &World, anchor: &[f64; 6], pose: &[f64; 6]| {
        let mut out = [0f32; 14];
        net.set_anchor(world, anchor, 1.0);
        net.predict_at(pose, &vector, &mut out);
        // The same through the parts: the map at the anchor, the offset of the pose from it.
        let mut map = vec![0f32; MAP_SIZE * MAP_SIZE];
        map_features(world, anchor, 1.0, &mut map);
        let mut parts = [0f32; 14];
        net.embed(&map);
        net.predict(&vector, &offset_features(anchor, pose, 1.0), &mut parts);
        assert_eq!(out, parts);
        assert_eq!(out[2], out[9], "the members agree");
        out[2]
    };
    let here = up(&mut net, &ramp, &anchor, &anchor);
    assert!(here.abs() > 1e-4, "{here}");
    let on_flat = up(&mut net, &flat(0.5), &anchor, &anchor);
    assert!(
        (here - on_flat).abs() > 1e-5,
        "the map matters: {here} vs {on_flat}"
    );
    let ahead = up(&mut net, &ramp, &anchor, &[4.0, 1.0, 0.8, 0.0, 0.0, 0.3]);
    assert!(
        (here - ahead).abs() > 1e-5,
        "the offset matters: {here} vs {ahead}"
    );
    // Only the map relative to the anchor and the offset from it count: the same pair 10 m further up the ramp (2 m
    // higher), where the relative map is the same, predicts the same.
    let (a2, p2) = (
        [10.0, 0.0, 2.0, 0.0, 0.0, 0.0],
        [14.0, 1.0, 2.8, 0.0, 0.0, 0.3],
    );
    let shifted = up(&mut net, &ramp, &a2, &p2);
    assert!((shifted - ahead).abs() < 1e-5, "{shifted} vs {ahead}");
}

#[test]
fn tal_with_a_hand_built_model_reaches_goals_ahead_and_beside_deterministically() {
    let net = TalNet::from_bytes(&bicycle_like(tal_metadata(2))).unwrap();
    reaches_goals(&Dynamics::from(net), Rollout::Learned);
}

#[test]
fn mppi6_and_wmvct_with_a_hand_built_model_reach_goals_ahead_and_beside_deterministically() {
    let net = KinoNet::from_bytes(&bicycle_like(metadata(2))).unwrap();
    for rollout in [Rollout::Learned, Rollout::Decomposed] {
        reaches_goals(&Dynamics::from(net.clone()), rollout);
    }
}

/// MPPI-6 (16 samples, 6 steps) rolling out `net` drives the HMMWV on flat rigid ground to goals ahead and to
/// either side, and the same episode again gives the same metrics.
fn reaches_goals(net: &Dynamics, rollout: Rollout) {
    reaches_goals_with(net, rollout, None);
}

fn reaches_goals_with(net: &Dynamics, rollout: Rollout, estimator: Option<&TravNet>) {
    let w = &flat(1.0);
    let spec = &vehicle_by_name("hmmwv").unwrap();
    let cfg = &EpisodeConfig {
        max_time: 40.0,
        ..Default::default()
    };
    let small = KinoMppiConfig {
        samples: 16,
        horizon_steps: 6,
        rollout,
        ..Default::default()
    };
    for goal in [[40.0, 0.0], [10.0, 40.0], [10.0, -40.0]] {
        let task = Task {
            world_id: 1,
            index: 0,
            start: [0.0, 0.0],
            goal,
            path: vec![[0.0, 0.0], goal],
        };
        let make = || {
            let p = KinoMppi::new("mppi6", net.clone(), small);
            match estimator {
                Some(t) => p.with_traversability(t.clone()),
                None => p,
            }
        };
        let mut p = make();
        let r = sim_core::run_episode(w, &task, spec, &mut p, cfg);
        assert_eq!(
            r.outcome,
            Outcome::Success,
            "{small:?} goal {goal:?}: {r:?}"
        );
        assert!(p.decisions > 5 && p.predictions >= p.decisions * 16);
        let mut again = make();
        let r2 = sim_core::run_episode(w, &task, spec, &mut again, cfg);
        assert_eq!(r.metrics, r2.metrics, "deterministic");
    }
}

/// Flat rigid ground of `cell`-metre cells.
fn flat(cell: f64) -> World {
    World::uniform(
        Heightmap::from_fn(cell, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    )
}

/// An estimator that flags raised ground: the map's height passed through the centre taps of every convolution,
/// `stuck` (ahead heading) = sigmoid(20 x height - 5), every other output sigmoid(-10).
fn block_finder() -> Vec<u8> {
    let tap = |out: usize, inp: usize, k: usize| {
        let mut w = vec![0f32; out * inp * k * k];
        w[k * k / 2] = 1.0; // filter 0, input channel 0, centre
        w
    };
    let outputs = HEADINGS * CHANNELS.len();
    let mut out_w = vec![0f32; outputs * 2];
    out_w[3 * 2] = 20.0; // heading 0, channel `stuck` (3), from channel 0
    let mut out_b = vec![-10f32; outputs];
    out_b[3] = -5.0;
    let tensors: Tensors = vec![
        ("conv1.weight".into(), vec![8, 1, 3, 3], tap(8, 1, 3)),
        ("conv1.bias".into(), vec![8], vec![0.0; 8]),
        ("conv2.weight".into(), vec![2, 8, 3, 3], tap(2, 8, 3)),
        ("conv2.bias".into(), vec![2], vec![0.0; 2]),
        ("conv3.weight".into(), vec![2, 2, 3, 3], tap(2, 2, 3)),
        ("conv3.bias".into(), vec![2], vec![0.0; 2]),
        ("out.weight".into(), vec![outputs, 2, 1, 1], out_w),
        ("out.bias".into(), vec![outputs], out_b),
    ];
    let meta = [
        ("format", TNT_LAYOUT.to_string()),
        ("channels", CHANNELS.join(",")),
        ("headings", HEADINGS.to_string()),
        ("grid", GRID_META.to_string()),
        ("map", MAP_META.to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    to_bytes(tensors, meta)
}

#[test]
fn the_estimator_finds_a_block_where_it_stands_in_the_anchors_frame_whichever_way_it_faces() {
    let mut net = TravNet::from_bytes(&block_finder()).unwrap();
    let low = 1.0 / (1.0 + 5f64.exp()); // sigmoid(-5)
    for yaw in [0.0, std::f64::consts::FRAC_PI_2, -2.5] {
        // A block 1 m high, 2 m square, 7 m ahead and 3 m to the left of an anchor at the origin facing `yaw`.
        let (s, c) = f64::sin_cos(yaw);
        let at = |fwd: f64, left: f64| (c * fwd - s * left, s * fwd + c * left);
        let (bx, by) = at(7.0, 3.0);
        let world = World::uniform(
            Heightmap::from_fn(0.25, |x, y| {
                f64::from(u8::from((x - bx).abs() < 1.0 && (y - by).abs() < 1.0))
            }),
            Semantic::Dirt,
            Surface::Rigid { friction: 0.8 },
        );
        net.set_anchor(&world, &[0.0, 0.0, 0.0, 0.0, 0.0, yaw], 1.0);
        let pose = |fwd: f64, left: f64| {
            let (x, y) = at(fwd, left);
            [x, y, 0.0, 0.0, 0.0, yaw]
        };
        let on = net.at(&pose(7.0, 3.0)).unwrap();
        assert!(on[3] > 0.99, "yaw {yaw}: stuck {} on the block", on[3]);
        for (f, l) in [(7.0, -3.0), (3.0, 3.0), (11.0, 3.0), (7.0, 7.0)] {
            let off = net.at(&pose(f, l)).unwrap();
            assert!(
                (f64::from(off[3]) - low).abs() < 1e-6,
                "yaw {yaw}: {f} ahead, {l} left: {off:?}"
            );
        }
        assert_eq!(net.at(&pose(-4.0, 0.0)), None, "behind the grid");
        let cost = net.cost(&pose(7.0, 3.0));
        let want: f64 = on
            .iter()
            .zip(CHANNEL_WEIGHTS)
            .map(|(&v, w)| f64::from(v) * w)
            .sum();
        assert!((cost - want).abs() < 1e-12 && cost > 0.19, "{cost}");
        assert_eq!(net.cost(&pose(-4.0, 0.0)), 0.0);
    }
}

#[test]
fn tnt_with_a_hand_built_model_and_estimator_reaches_goals_ahead_and_beside_deterministically() {
    let net = TalNet::from_bytes(&bicycle_like(tal_metadata(2))).unwrap();
    let estimator = TravNet::from_bytes(&block_finder()).unwrap();
    reaches_goals_with(&Dynamics::from(net), Rollout::Learned, Some(&estimator));
}
