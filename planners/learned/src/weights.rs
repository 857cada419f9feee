//! Writing weights files: the metadata every `vertibench-policy-v1` file carries, and an untrained policy (seeded,
//! for tests and for the shape of a file; trained ones come from `python -m vertibench.train`).

use crate::features::{CROP_CHANNELS, FEATURES, LAYOUT};
use crate::net::{ACTIONS, ACTOR_INPUTS, CROP_CELL_META, CROP_META};
use safetensors::tensor::{Dtype, TensorView};
use std::collections::HashMap;

/// The metadata this build requires of a weights file, for a policy named `name` acting at `control_rate_hz`.
pub fn layout_metadata(name: &str, control_rate_hz: f64, vehicle: &str) -> HashMap<String, String> {
    [
        ("format", LAYOUT.to_string()),
        ("features", FEATURES.join(",")),
        ("crop", CROP_META.to_string()),
        ("crop_cell_per_scale", CROP_CELL_META.to_string()),
        ("action", ACTIONS.join(",")),
        ("control_rate_hz", control_rate_hz.to_string()),
        ("vehicle", vehicle.to_string()),
        ("name", name.to_string()),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// A weights file of an untrained actor (`hidden` wide; weights uniform in +-1/sqrt(fan-in), from `seed`) with
/// `metadata`.
pub fn untrained(seed: u64, hidden: usize, metadata: HashMap<String, String>) -> Vec<u8> {
    let mut state = seed ^ 0x9e37_79b9_7f4a_7c15;
    let mut next = move || {
        // splitmix64
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    };
    let shapes: [(&str, Vec<usize>); 10] = [
        ("enc.conv1.weight", vec![8, CROP_CHANNELS, 4, 4]),
        ("enc.conv1.bias", vec![8]),
        ("enc.conv2.weight", vec![16, 8, 3, 3]),
        ("enc.conv2.bias", vec![16]),
        ("pi.fc1.weight", vec![hidden, ACTOR_INPUTS]),
        ("pi.fc1.bias", vec![hidden]),
        ("pi.fc2.weight", vec![hidden, hidden]),
        ("pi.fc2.bias", vec![hidden]),
        ("pi.mean.weight", vec![ACTIONS.len(), hidden]),
        ("pi.mean.bias", vec![ACTIONS.len()]),
    ];
    let data: Vec<(&str, Vec<usize>, Vec<u8>)> = shapes
        .into_iter()
        .map(|(name, shape)| {
            let fan_in: usize = if shape.len() > 1 {
                shape[1..].iter().product()
            } else {
                4
            };
            let bound = 1.0 / (fan_in as f64).sqrt();
            let n: usize = shape.iter().product();
            let bytes = (0..n)
                .flat_map(|_| (((next() * 2.0 - 1.0) * bound) as f32).to_le_bytes())
                .collect();
            (name, shape, bytes)
        })
        .collect();
    let views = data.iter().map(|(name, shape, bytes)| {
        let view =
            TensorView::new(Dtype::F32, shape.clone(), bytes).expect("shape matches the data");
        (*name, view)
    });
    safetensors::tensor::serialize(views, Some(metadata)).expect("serialising in memory")
}
