//! `validate` names what is wrong (file and field) and never panics, whatever the directory holds.

mod common;

use common::*;
use datasets::frames::{columns, FrameColumns};
use datasets::parquet_io::{write_table, Data};
use datasets::parquet_read::read_table;
use datasets::{DatasetKind, Variant};
use std::path::{Path, PathBuf};

fn dataset(name: &str, variant: Variant) -> (PathBuf, datasets::DatasetSpec) {
    let dir = tmpdir(name);
    let spec = spec(DatasetKind::Failures, variant);
    write(&dir, &spec, 10, tiny());
    assert!(datasets::validate(&dir).unwrap().is_ok());
    (dir, spec)
}

fn problems(dir: &Path) -> (datasets::Report, String) {
    let r = datasets::validate(dir).unwrap();
    let text = r.to_string();
    (r, text)
}

/// Rewrites a data file through `edit` (keeping its footer), as another writer might have.
fn edit_data(
    dir: &Path,
    spec: &datasets::DatasetSpec,
    rel: &str,
    edit: impl FnOnce(&mut FrameColumns),
) {
    let path = dir.join(rel);
    let table = read_table(&path, &columns(spec)).unwrap();
    let footer: Vec<(String, String)> = table.metadata.clone().into_iter().collect();
    let mut f = FrameColumns::from_table(spec, table).unwrap();
    edit(&mut f);
    std::fs::write(
        &path,
        write_table(&path, f.into_columns(spec), &footer).unwrap(),
    )
    .unwrap();
}

#[test]
fn corrupted_files_are_named() {
    let (d, spec) = dataset("corrupt", Variant::Lite);
    let rel = "data/chunk-000/file-001.parquet";
    let bytes = std::fs::read(d.join(rel)).unwrap();
    std::fs::write(d.join(rel), &bytes[..bytes.len() / 2]).unwrap();
    let (r, text) = problems(&d);
    assert!(!r.is_ok());
    assert!(r.problems.iter().any(|p| p.file == rel), "{text}");
    assert!(
        text.contains("meta/stats.json") || !text.contains("panicked"),
        "{text}"
    );
    std::fs::write(d.join(rel), &bytes).unwrap();
    assert!(datasets::validate(&d).unwrap().is_ok());

    // Values changed behind the writer's back: each check names its column.
    edit_data(&d, &spec, rel, |f| {
        f.timestamp[3] += 1.0;
        f.task_index[4] = 7;
        f.done[5] = !f.done[5];
        f.reward[6] += 0.5;
        f.frame_index[8] = 99;
    });
    let (_, text) = problems(&d);
    for field in [
        "`timestamp`: row 3",
        "`task_index`: row 4",
        "`next.done`: row 5",
        "`next.reward`: row 6",
        "`frame_index`: row 8",
    ] {
        assert!(text.contains(&format!("{rel}: {field}")), "{field}: {text}");
    }
    assert!(
        text.contains("meta/stats.json: does not match the data"),
        "{text}"
    );
    std::fs::write(d.join(rel), &bytes).unwrap();

    // Two data files swapped: indices and episodes out of order.
    let other = "data/chunk-000/file-000.parquet";
    let first = std::fs::read(d.join(other)).unwrap();
    std::fs::write(d.join(other), &bytes).unwrap();
    std::fs::write(d.join(rel), &first).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains(&format!("{other}: `index`"))
            && text.contains(&format!("{other}: `episode_index`")),
        "{text}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn meta_files_are_checked() {
    let (d, spec) = dataset("meta", Variant::Full);
    let info_path = d.join("meta/info.json");
    let info = std::fs::read_to_string(&info_path).unwrap();

    std::fs::write(&info_path, "{ not json").unwrap();
    let (r, text) = problems(&d);
    assert!(
        !r.complete && text.contains("meta/info.json: invalid JSON"),
        "{text}"
    );
    assert_eq!(
        r.episodes, 10,
        "the data are still checked, with the spec from the files' footers"
    );
    assert!(datasets::info(&d).is_err());

    let mut v: serde_json::Value = serde_json::from_str(&info).unwrap();
    v["total_frames"] = 5.into();
    v["features"]["observation.state"]["shape"] = serde_json::json!([14]);
    v["vertibench"]["spec"]["seed"] = 1.into();
    std::fs::write(&info_path, serde_json::to_string(&v).unwrap()).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains("meta/info.json: `total_frames`: 5, the files hold"),
        "{text}"
    );
    assert!(
        text.contains("meta/info.json: `features.observation.state`"),
        "{text}"
    );
    assert!(
        text.contains("`vertibench.spec`: the footer's spec is not meta/info.json's"),
        "{text}"
    );
    std::fs::write(&info_path, &info).unwrap();

    let stats_path = d.join("meta/stats.json");
    let stats = std::fs::read_to_string(&stats_path).unwrap();
    let mut s: serde_json::Value = serde_json::from_str(&stats).unwrap();
    s["action"]["mean"][1] = 123.0.into();
    std::fs::write(&stats_path, serde_json::to_string(&s).unwrap()).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains("meta/stats.json: does not match the data: `action.mean[1]` is 123.0"),
        "{text}"
    );
    std::fs::write(&stats_path, &stats).unwrap();

    std::fs::remove_file(d.join("meta/episodes/chunk-001/file-000.parquet")).unwrap();
    std::fs::remove_file(d.join("README.md")).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains("meta/episodes/chunk-001/file-000.parquet: missing"),
        "{text}"
    );
    assert!(text.contains("README.md: missing"), "{text}");

    // A data file with another schema: the column is named.
    let rel = "data/chunk-000/file-000.parquet";
    let mut cols = columns(&spec);
    cols[0].1 = datasets::parquet_io::Kind::ListF64(vec![14]);
    let path = d.join(rel);
    let f = FrameColumns::from_table(&spec, read_table(&path, &columns(&spec)).unwrap()).unwrap();
    let rows = f.rows;
    let mut data: Vec<_> = f.into_columns(&spec);
    let state = data[0].clone();
    data[0] = (
        cols[0].0.clone(),
        cols[0].1.clone(),
        Data::ListF64(vec![0.5; 14 * rows]),
    );
    std::fs::write(&path, write_table(&path, data.clone(), &[]).unwrap()).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains(&format!(
            "{rel}: column `observation.state`: row 0: 14 values, expected a list of shape [15]"
        )),
        "{text}"
    );
    // The state as float32 (the format's former type): the column's type is named.
    let Data::ListF64(v) = &state.2 else {
        panic!("state is float64")
    };
    data[0] = (
        state.0.clone(),
        datasets::parquet_io::Kind::ListF32(vec![15]),
        Data::ListF32(v.iter().map(|&x| x as f32).collect()),
    );
    std::fs::write(&path, write_table(&path, data, &[]).unwrap()).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains(&format!(
            "{rel}: schema: column `observation.state`: expected"
        )) && text.contains("DOUBLE")
            && text.contains("FLOAT"),
        "{text}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

/// Every file of a dataset replaced by garbage or cut short, one at a time: a report naming it, never a panic.
#[test]
fn damaged_input_never_panics() {
    let (d, _) = dataset("garbage", Variant::Full);
    let files = files(&d);
    for (rel, bytes) in &files {
        if rel.starts_with("card/") || rel == "README.md" {
            continue;
        }
        let garbage: Vec<u8> = (0..bytes.len()).map(|i| (i * 7919 % 251) as u8).collect();
        let mut cuts = vec![
            garbage,
            Vec::new(),
            bytes[..bytes.len() / 3].to_vec(),
            bytes[..bytes.len() - 9].to_vec(),
        ];
        // A flipped byte in the middle of the file (inside column data, for the parquet files).
        let mut flipped = bytes.clone();
        let mid = flipped.len() / 2;
        flipped[mid] ^= 0x5a;
        cuts.push(flipped);
        for (k, b) in cuts.iter().enumerate() {
            std::fs::write(d.join(rel), b).unwrap();
            let r = datasets::validate(&d).unwrap();
            let named = r.problems.iter().any(|p| p.file == *rel);
            // A flipped byte in info.json may hit a checksum: the file it lists is named instead.
            let info_flip = k == 4 && rel == "meta/info.json";
            assert!(!r.is_ok() && (named || info_flip), "{rel}, damage {k}: {r}");
            let _ = datasets::info(&d);
        }
        std::fs::write(d.join(rel), bytes).unwrap();
    }
    assert!(datasets::validate(&d).unwrap().is_ok());
    assert!(datasets::validate(&d.join("nope")).is_err());
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn incomplete_and_foreign_directories_are_reported() {
    let spec = spec(DatasetKind::Expert, Variant::Lite);
    let d = tmpdir("incomplete");
    let mut w = datasets::DatasetWriter::open_with(&d, &spec, "x", tiny()).unwrap();
    for i in 0..5 {
        w.append(&record(&spec, i)).unwrap();
    }
    drop(w);
    let (r, text) = problems(&d);
    assert!(!r.complete && r.episodes > 0, "{text}");
    assert!(
        text.contains("incomplete") && text.contains("`vertibench.complete`"),
        "{text}"
    );
    assert!(datasets::info(&d).unwrap().contains("incomplete"));
    std::fs::write(d.join("stray.csv"), b"a,b").unwrap();
    let (_, text) = problems(&d);
    assert!(text.contains("stray.csv: not part of a dataset"), "{text}");
    let e = tmpdir("empty");
    std::fs::create_dir_all(&e).unwrap();
    let (r, text) = problems(&e);
    assert!(!r.is_ok() && text.contains("no spec"), "{text}");
    for x in [d, e] {
        std::fs::remove_dir_all(x).unwrap();
    }
}

/// Each episode's final observation: read back, and a non-finite value or a list of another length is named.
#[test]
fn final_observations_are_checked() {
    use datasets::episodes::{columns as episode_columns, read_episodes, write_episodes};
    let (d, spec) = dataset("final-observation", Variant::Lite);
    let rel = "meta/episodes/chunk-000/file-000.parquet";
    let path = d.join(rel);
    let table = read_table(&path, &episode_columns()).unwrap();
    let footer: Vec<(String, String)> = table.metadata.clone().into_iter().collect();
    let mut rows = read_episodes(&path, &spec).unwrap();
    for r in &rows {
        let want = record(&spec, r.index).meta;
        assert_eq!(
            r.meta.final_state.map(f64::to_bits),
            want.final_state.map(f64::to_bits)
        );
        assert_eq!(
            r.meta.final_goal.map(f64::to_bits),
            want.final_goal.map(f64::to_bits)
        );
    }
    rows[0].meta.final_state[2] = f64::NAN;
    rows[0].meta.final_goal[1] = f64::INFINITY;
    std::fs::write(&path, write_episodes(&path, &spec, &rows, &footer).unwrap()).unwrap();
    let (r, text) = problems(&d);
    assert!(!r.is_ok());
    assert!(
        text.contains("`final_state`: episode 0: value 2 is NaN (values must be finite)"),
        "{text}"
    );
    assert!(
        text.contains("`final_goal`: episode 0: value 1 is inf (values must be finite)"),
        "{text}"
    );

    // A final goal of 2 values instead of 3.
    let mut cols: Vec<_> = episode_columns()
        .into_iter()
        .zip(read_table(&path, &episode_columns()).unwrap().columns)
        .map(|((n, k), d)| (n, k, d))
        .collect();
    let i = cols.iter().position(|(n, _, _)| n == "final_goal").unwrap();
    cols[i].1 = datasets::parquet_io::Kind::ListF64(vec![2]);
    cols[i].2 = Data::ListF64(vec![0.25; 2 * rows.len()]);
    std::fs::write(&path, write_table(&path, cols, &footer).unwrap()).unwrap();
    let (_, text) = problems(&d);
    assert!(
        text.contains(&format!(
            "{rel}: column `final_goal`: row 0: 2 values, expected a list of shape [3]"
        )),
        "{text}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}
