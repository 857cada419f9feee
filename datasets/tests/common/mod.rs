//! Synthetic episodes and helpers shared by the dataset tests.
#![allow(dead_code)]

use contracts::{ElevationLevel, EndReason, ObstacleDensity, Outcome, SemanticsKind, TaskId};
use datasets::{
    CropSpec, DatasetKind, DatasetSpec, EpisodeMeta, FailureClass, FailureWindow, Frames,
    RecordedEpisode, SpeedProfile, Variant, WriterOptions,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub const FPS: f64 = 10.0;
pub const CROP: usize = 6;

pub fn spec(kind: DatasetKind, variant: Variant) -> DatasetSpec {
    DatasetSpec {
        kind,
        variant,
        vehicle: "test-rover".into(),
        wheels: 4,
        scale: 1.0 / 6.0,
        control_rate_hz: FPS,
        crop: CropSpec {
            size: CROP,
            resolution: 0.25,
        },
        sim_version: "0.1.0+test".into(),
        task_set_version: "test-set".into(),
        task_set_seed: Some(7),
        seed: 42,
        speed_profile: SpeedProfile::Constant,
        analysis_only: false,
    }
}

/// Tiny data files (a few episodes each) in chunks of two files, so rollovers of both happen.
pub fn tiny() -> WriterOptions {
    WriterOptions {
        data_files_size_in_mb: 0.012,
        chunks_size: 2,
        task_set: None,
    }
}

/// Frames of episode `i`.
pub fn len(i: u64) -> usize {
    20 + (i as usize * 7) % 13
}

/// Value of frame `t` of episode `i`, component `c` of a feature numbered `f`: distinct and exactly representable.
pub fn val(i: u64, t: usize, f: usize, c: usize) -> f32 {
    (i as f32) * 100.0 + (t as f32) * 0.5 + (f as f32) * 0.125 + (c as f32) * 0.0625 - 30.0
}

/// A crop value (float16-exact).
pub fn crop_val(i: u64, t: usize, k: usize, which: usize) -> f32 {
    ((i as usize * 3 + t + k + which * 5) % 32) as f32 * 0.25 - 2.0
}

pub fn record(spec: &DatasetSpec, i: u64) -> RecordedEpisode {
    let n = len(i);
    let outcomes = [
        Outcome::Success,
        Outcome::Rollover,
        Outcome::Stuck,
        Outcome::Timeout,
    ];
    let outcome = match spec.kind {
        DatasetKind::Expert => Outcome::Success,
        _ => outcomes[i as usize % 4],
    };
    let reason = match outcome {
        Outcome::Success => EndReason::Success,
        Outcome::Rollover => EndReason::Rollover,
        Outcome::Stuck => EndReason::Stuck,
        _ => EndReason::Timeout,
    };
    // Frame `t`'s state; `t == n` is the final observation. float64 values that float32 cannot hold (the pose is
    // stored unrounded).
    let state_at = |t: usize| {
        let mut s = [0f64; 15];
        for (c, v) in s.iter_mut().enumerate() {
            *v = f64::from(val(i, t, 0, c)) + 1e-10 * c as f64;
        }
        // Plausible positions, angles and speeds for the card's pictures.
        s[0] = (i as f64) * 2.0 + t as f64 * 0.25 - 10.0 + 1e-12;
        s[1] = (t as f64 * 0.3).sin() * 3.0 + i as f64;
        s[3] = (t as f64 * 0.1).sin() * 0.2;
        s[4] = (t as f64 * 0.07).cos() * 0.1;
        s[5] = (t as f64 * 0.05).sin() * std::f64::consts::PI;
        s[12] = 1.0 + t as f64 * 0.05;
        s[14] = t as f64 / FPS;
        s
    };
    let goal_at =
        |t: usize| -> [f64; 3] { std::array::from_fn(|c| f64::from(val(i, t, 1, c)) / 3.0) };
    let state: Vec<[f64; 15]> = (0..n).map(state_at).collect();
    let arr = |f: usize| -> Vec<[f32; 3]> {
        (0..n)
            .map(|t| std::array::from_fn(|c| val(i, t, f, c)))
            .collect()
    };
    let crops = |which: usize| {
        (spec.variant == Variant::Full).then(|| {
            (0..n)
                .flat_map(|t| (0..CROP * CROP).map(move |k| crop_val(i, t, k, which)))
                .collect()
        })
    };
    let frames = Frames {
        state,
        goal: (0..n).map(goal_at).collect(),
        wheels: (0..n)
            .flat_map(|t| (0..spec.wheels * 4).map(move |c| val(i, t, 2, c)))
            .collect(),
        action: arr(3),
        reward_terms: (0..n)
            .map(|t| std::array::from_fn(|c| val(i, t, 4, c) / 64.0))
            .collect(),
        terminated: (0..n)
            .map(|t| t == n - 1 && outcome != Outcome::Timeout)
            .collect(),
        truncated: (0..n)
            .map(|t| t == n - 1 && outcome == Outcome::Timeout)
            .collect(),
        elevation: crops(0),
        semantics: crops(1),
    };
    let failure = (spec.kind == DatasetKind::Failures).then(|| FailureWindow {
        class: if i.is_multiple_of(2) {
            FailureClass::Rollover
        } else {
            FailureClass::Stuck
        },
        source: "random".into(),
        source_episode: i * 10,
        start_time: 3.5,
        short: i.is_multiple_of(3),
    });
    let meta = EpisodeMeta {
        kind: spec.kind,
        task_id: i
            .is_multiple_of(2)
            .then(|| TaskId::new(1 + i as u32 % 3, i as u32 % 10)),
        world_id: 1 + i as u32 % 3,
        level: ElevationLevel::ALL[i as usize % 3],
        semantics: SemanticsKind::ALL[(i as usize / 3) % 3],
        density: ObstacleDensity::ALL[(i as usize / 2) % 3],
        start_ground: "gravel".into(),
        start: [i as f64, -1.5, 0.25],
        goal: [i as f64 + 8.0, 2.0],
        policy: match spec.kind {
            DatasetKind::Random => "sinusoid".into(),
            _ => "pid".into(),
        },
        policy_params: BTreeMap::from([("speed".to_string(), 2.0), ("period".to_string(), 4.5)]),
        seed: 1_000_000_007 * i + u64::MAX / 2,
        outcome,
        reason,
        failure,
        final_state: state_at(n),
        final_goal: goal_at(n),
    };
    RecordedEpisode { meta, frames }
}

pub fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vb-datasets-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// Every file under `dir`, relative, with its bytes, sorted.
pub fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    fn walk(root: &Path, d: &Path, out: &mut Vec<(String, Vec<u8>)>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().display().to_string();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    let mut out = Vec::new();
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Asserts two dataset directories hold the same files, byte for byte.
pub fn assert_same(a: &Path, b: &Path) {
    let (fa, fb) = (files(a), files(b));
    let names = |f: &[(String, Vec<u8>)]| f.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(names(&fa), names(&fb), "file lists differ");
    for ((n, x), (_, y)) in fa.iter().zip(&fb) {
        assert!(x == y, "{n} differs");
    }
}

/// Writes episodes `0..n` of `spec` into `dir` with `options` and finishes.
pub fn write(
    dir: &Path,
    spec: &DatasetSpec,
    n: u64,
    options: WriterOptions,
) -> datasets::WrittenDataset {
    let mut w =
        datasets::DatasetWriter::open_with(dir, spec, "vb dataset generate --test", options)
            .unwrap();
    for i in w.resume_point().episodes..n {
        w.append(&record(spec, i)).unwrap();
    }
    w.finish().unwrap()
}
