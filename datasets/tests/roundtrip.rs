//! A small dataset written from synthetic episodes (lite and full, tiny data files so several files and chunk
//! directories happen), read back with the parquet crate's own record reader, column by column, and validated.

mod common;

use common::*;
use datasets::record::{STATE_FIELDS, WHEEL_FIELDS};
use datasets::{DatasetKind, DatasetSpec, Variant};
use parquet::file::reader::{FileReader, SerializedFileReader};
use parquet::record::{List, ListAccessor, Row, RowAccessor};
use std::path::Path;

fn rows(path: &Path) -> Vec<Row> {
    let r = SerializedFileReader::new(std::fs::File::open(path).unwrap()).unwrap();
    r.get_row_iter(None).unwrap().map(|r| r.unwrap()).collect()
}

fn col(row: &Row, name: &str) -> usize {
    row.get_column_iter()
        .position(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no column {name}"))
}

fn floats(l: &List) -> Vec<f32> {
    (0..l.len()).map(|k| l.get_float(k).unwrap()).collect()
}

/// A float64 list's values, as bits (the pose must come back bit for bit).
fn double_bits(l: &List) -> Vec<u64> {
    (0..l.len())
        .map(|k| l.get_double(k).unwrap().to_bits())
        .collect()
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn nested_floats(l: &List, inner: usize) -> Vec<f32> {
    let mut out = Vec::new();
    for k in 0..l.len() {
        let li = l.get_list(k).unwrap();
        assert_eq!(li.len(), inner);
        out.extend(floats(li));
    }
    out
}

fn nested_f16(l: &List, inner: usize) -> Vec<f32> {
    let mut out = Vec::new();
    for k in 0..l.len() {
        let li = l.get_list(k).unwrap();
        assert_eq!(li.len(), inner);
        out.extend((0..li.len()).map(|j| li.get_float16(j).unwrap().to_f32()));
    }
    out
}

/// Reads every data file and checks every column of every frame against the episodes that were written.
fn check_data(dir: &Path, spec: &DatasetSpec, n: u64) {
    let info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("meta/info.json")).unwrap()).unwrap();
    let episodes: Vec<Row> = glob(dir, "meta/episodes")
        .iter()
        .flat_map(|p| rows(p))
        .collect();
    assert_eq!(episodes.len() as u64, n);
    let mut frames = Vec::new();
    for p in glob(dir, "data") {
        frames.extend(rows(&p));
    }
    assert_eq!(frames.len() as u64, info["total_frames"].as_u64().unwrap());
    let tasks = rows(&dir.join("meta/tasks.parquet"));
    let mut g = 0usize;
    for i in 0..n {
        let rec = record(spec, i);
        let ep = &episodes[i as usize];
        assert_eq!(ep.get_long(col(ep, "episode_index")).unwrap(), i as i64);
        assert_eq!(ep.get_long(col(ep, "length")).unwrap(), len(i) as i64);
        assert_eq!(
            ep.get_long(col(ep, "dataset_from_index")).unwrap(),
            g as i64
        );
        assert_eq!(
            ep.get_long(col(ep, "dataset_to_index")).unwrap(),
            (g + len(i)) as i64
        );
        assert_eq!(
            ep.get_long(col(ep, "world_id")).unwrap(),
            i64::from(rec.meta.world_id)
        );
        assert_eq!(
            ep.get_string(col(ep, "level")).unwrap(),
            rec.meta.level.as_str()
        );
        assert_eq!(
            ep.get_string(col(ep, "outcome")).unwrap(),
            rec.meta.outcome.as_str()
        );
        assert_eq!(ep.get_ulong(col(ep, "seed")).unwrap(), rec.meta.seed);
        assert_eq!(
            ep.get_string(col(ep, "policy_params")).unwrap(),
            r#"{"period":4.5,"speed":2.0}"#
        );
        assert_eq!(ep.get_string(col(ep, "vehicle")).unwrap(), "test-rover");
        assert_eq!(
            double_bits(ep.get_list(col(ep, "final_state")).unwrap()),
            bits(&rec.meta.final_state)
        );
        assert_eq!(
            double_bits(ep.get_list(col(ep, "final_goal")).unwrap()),
            bits(&rec.meta.final_goal)
        );
        let task_id = ep.get_string(col(ep, "task_id")).ok().cloned();
        assert_eq!(task_id, rec.meta.task_id.map(|t| t.to_string()));
        let task = ep
            .get_list(col(ep, "tasks"))
            .unwrap()
            .get_string(0)
            .unwrap()
            .clone();
        let task_index = tasks
            .iter()
            .position(|t| t.get_string(1).unwrap() == &task)
            .unwrap();
        let (chunk, file) = (
            ep.get_long(col(ep, "data/chunk_index")).unwrap(),
            ep.get_long(col(ep, "data/file_index")).unwrap(),
        );
        let data_file = dir.join(format!("data/chunk-{chunk:03}/file-{file:03}.parquet"));
        let in_file = rows(&data_file);
        assert!(in_file
            .iter()
            .any(|r| r.get_long(col(r, "episode_index")).unwrap() == i as i64));
        for t in 0..len(i) {
            let r = &frames[g];
            let list = |name: &str| r.get_list(col(r, name)).unwrap();
            assert_eq!(
                double_bits(list("observation.state")),
                bits(&rec.frames.state[t])
            );
            assert_eq!(
                double_bits(list("observation.goal")),
                bits(&rec.frames.goal[t])
            );
            assert_eq!(
                nested_floats(list("observation.wheels"), 4),
                rec.frames.wheels[t * 16..t * 16 + 16].to_vec()
            );
            assert_eq!(list("observation.wheels").len(), spec.wheels);
            assert_eq!(floats(list("action")), rec.frames.action[t].to_vec());
            let terms = rec.frames.reward_terms[t];
            assert_eq!(floats(list("next.reward_terms")), terms.to_vec());
            assert_eq!(
                r.get_float(col(r, "next.reward")).unwrap(),
                terms[0] + terms[1] + terms[2] + terms[3]
            );
            let (te, tr) = (rec.frames.terminated[t], rec.frames.truncated[t]);
            assert_eq!(r.get_bool(col(r, "next.terminated")).unwrap(), te);
            assert_eq!(r.get_bool(col(r, "next.truncated")).unwrap(), tr);
            assert_eq!(r.get_bool(col(r, "next.done")).unwrap(), te || tr);
            assert_eq!(
                r.get_float(col(r, "timestamp")).unwrap(),
                (t as f64 / FPS) as f32
            );
            assert_eq!(r.get_long(col(r, "frame_index")).unwrap(), t as i64);
            assert_eq!(r.get_long(col(r, "episode_index")).unwrap(), i as i64);
            assert_eq!(r.get_long(col(r, "index")).unwrap(), g as i64);
            assert_eq!(r.get_long(col(r, "task_index")).unwrap(), task_index as i64);
            let cells = CROP * CROP;
            match spec.variant {
                Variant::Full => {
                    let want = |c: &Option<Vec<f32>>| {
                        c.as_ref().unwrap()[t * cells..(t + 1) * cells].to_vec()
                    };
                    assert_eq!(
                        nested_f16(list("observation.elevation"), CROP),
                        want(&rec.frames.elevation)
                    );
                    assert_eq!(
                        nested_f16(list("observation.semantics"), CROP),
                        want(&rec.frames.semantics)
                    );
                }
                Variant::Lite => assert!(r
                    .get_column_iter()
                    .all(|(n, _)| n != "observation.elevation")),
            }
            g += 1;
        }
    }
}

/// The parquet files under `dir/<base>`, in chunk and file order.
fn glob(dir: &Path, base: &str) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut chunks: Vec<_> = std::fs::read_dir(dir.join(base))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    chunks.sort();
    for c in chunks {
        let mut files: Vec<_> = std::fs::read_dir(&c)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        out.extend(files);
    }
    out
}

fn roundtrip(kind: DatasetKind, variant: Variant, n: u64) {
    let dir = tmpdir(&format!("roundtrip-{kind:?}-{variant:?}"));
    let spec = spec(kind, variant);
    let summary = write(&dir, &spec, n, tiny());
    assert_eq!(summary.episodes, n);
    let frames: usize = (0..n).map(len).sum();
    assert_eq!(summary.frames, frames as u64);
    assert!(
        summary.data_files >= 4,
        "tiny files: several data files ({})",
        summary.data_files
    );
    assert!(
        dir.join("data/chunk-001/file-000.parquet").is_file(),
        "two files per chunk: a second chunk"
    );
    assert!(dir
        .join("meta/episodes/chunk-001/file-000.parquet")
        .is_file());
    check_data(&dir, &spec, n);

    let info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("meta/info.json")).unwrap()).unwrap();
    assert_eq!(info["codebase_version"], "v3.0");
    assert_eq!(info["robot_type"], "test-rover");
    assert_eq!(info["fps"], 10);
    assert_eq!(info["total_episodes"], n);
    assert_eq!(info["splits"]["train"], format!("0:{n}"));
    assert_eq!(info["chunks_size"], 2);
    assert_eq!(
        info["data_path"],
        "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    );
    assert_eq!(
        info["features"]["observation.state"]["shape"],
        serde_json::json!([15])
    );
    assert_eq!(
        info["features"]["observation.state"]["names"],
        serde_json::json!(STATE_FIELDS)
    );
    assert_eq!(info["features"]["observation.state"]["dtype"], "float64");
    assert_eq!(info["features"]["observation.goal"]["dtype"], "float64");
    assert_eq!(info["features"]["action"]["dtype"], "float32");
    assert_eq!(
        info["features"]["observation.wheels"]["shape"],
        serde_json::json!([4, 4])
    );
    assert_eq!(
        info["features"]["observation.wheels"]["names"]["field"],
        serde_json::json!(WHEEL_FIELDS)
    );
    assert_eq!(info["features"]["next.done"]["dtype"], "bool");
    assert_eq!(info["vertibench"]["complete"], true);
    assert_eq!(info["vertibench"]["spec"]["seed"], 42);
    assert_eq!(info["vertibench"]["command"], "vb dataset generate --test");
    let full = variant == Variant::Full;
    assert_eq!(
        info["features"].get("observation.elevation").is_some(),
        full
    );
    if full {
        assert_eq!(
            info["features"]["observation.elevation"]["dtype"],
            "float16"
        );
        assert_eq!(
            info["features"]["observation.elevation"]["shape"],
            serde_json::json!([CROP, CROP])
        );
    }

    let stats: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("meta/stats.json")).unwrap()).unwrap();
    assert_eq!(stats["index"]["count"], serde_json::json!([frames]));
    assert_eq!(stats["index"]["min"], serde_json::json!([0]));
    assert_eq!(stats["index"]["max"], serde_json::json!([frames - 1]));
    let mean = stats["index"]["mean"][0].as_f64().unwrap();
    assert!((mean - (frames - 1) as f64 / 2.0).abs() < 1e-9);
    assert_eq!(
        stats["observation.wheels"]["mean"]
            .as_array()
            .unwrap()
            .len(),
        4
    );
    assert_eq!(stats["next.done"]["max"], serde_json::json!([true]));

    let card = std::fs::read_to_string(dir.join("README.md")).unwrap();
    assert!(card.contains("vb dataset generate --test"));
    assert!(card.contains("### By elevation level") && card.contains("### By obstacle density"));
    assert!(dir.join("card/paths.png").is_file() && dir.join("card/roll.svg").is_file());

    let report = datasets::validate(&dir).unwrap();
    assert!(report.is_ok(), "{report}");
    assert_eq!(report.episodes, n);
    let text = datasets::info(&dir).unwrap();
    assert!(text.contains(&format!("{n} episodes")), "{text}");
    assert!(text.contains("complete"), "{text}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn lite_dataset_reads_back_column_by_column() {
    roundtrip(DatasetKind::Expert, Variant::Lite, 12);
}

#[test]
fn full_dataset_stores_float16_crops() {
    roundtrip(DatasetKind::Failures, Variant::Full, 9);
}

#[test]
fn random_dataset_names_its_task_by_policy() {
    let dir = tmpdir("tasks-random");
    let spec = spec(DatasetKind::Random, Variant::Lite);
    write(&dir, &spec, 3, datasets::WriterOptions::default());
    let tasks = rows(&dir.join("meta/tasks.parquet"));
    assert_eq!(tasks.len(), 1);
    assert_eq!(
        tasks[0].get_string(1).unwrap(),
        "random exploration: sinusoidal steering at 2 m/s"
    );
    assert!(dir.join("data/chunk-000/file-000.parquet").is_file());
    assert!(
        !dir.join("data/chunk-000/file-001.parquet").exists(),
        "100 MB files: one file"
    );
    let info: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("meta/info.json")).unwrap()).unwrap();
    assert_eq!(info["data_files_size_in_mb"], 100);
    assert_eq!(info["chunks_size"], 1000);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_card_draws_paths_over_the_task_sets_maps() {
    let ts = tasks::TaskSet::committed().unwrap();
    let mut spec = spec(DatasetKind::Random, Variant::Lite);
    spec.task_set_version = ts.version().to_string();
    let with_maps = || datasets::WriterOptions {
        task_set: Some(ts.clone()),
        ..tiny()
    };
    let (a, b) = (tmpdir("card-a"), tmpdir("card-b"));
    write(&a, &spec, 8, with_maps());
    write(&b, &spec, 8, with_maps());
    assert_same(&a, &b);
    let card = std::fs::read_to_string(a.join("README.md")).unwrap();
    assert!(card.contains("over the world's map"), "{card}");
    assert!(
        card.contains("world 1 (3 episodes), world 2 (3 episodes), world 3 (2 episodes)"),
        "{card}"
    );
    let png = image::open(a.join("card/paths.png")).unwrap();
    assert!(
        png.width() > 400 && png.height() > 400,
        "{}x{}",
        png.width(),
        png.height()
    );
    let svg = std::fs::read_to_string(a.join("card/pitch.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("Pitch") && svg.contains("degrees"));

    // A task set of another version than the spec's is refused when the card is drawn.
    let c = tmpdir("card-c");
    spec.task_set_version = "another-version".into();
    let mut w = datasets::DatasetWriter::open_with(&c, &spec, "x", with_maps()).unwrap();
    w.append(&record(&spec, 0)).unwrap();
    let msg = w.finish().err().unwrap().to_string();
    assert!(
        msg.contains(ts.version()) && msg.contains("another-version"),
        "{msg}"
    );
    assert!(!datasets::validate(&c).unwrap().complete);
    for d in [a, b, c] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
