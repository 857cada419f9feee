//! Reproducible and robust: the same episodes give byte-identical datasets however the run was interrupted and
//! resumed (crashes between any two appends, temporary files and half-committed files left behind, missing meta
//! files); a directory holding another dataset or other files is refused; bad records and IO errors are clear
//! errors, never panics, and leave a dataset that resumes.

mod common;

use common::*;
use datasets::{DatasetError, DatasetKind, DatasetWriter, Variant, WriterOptions};
use std::path::Path;

const N: u64 = 12;

/// Appends episodes `from..to` and drops the writer without finishing: a crash after the last append.
fn crash_after(
    dir: &Path,
    spec: &datasets::DatasetSpec,
    to: u64,
    command: &str,
) -> datasets::ResumePoint {
    let mut w = DatasetWriter::open_with(dir, spec, command, tiny()).unwrap();
    let from = w.resume_point().episodes;
    for i in from..to {
        w.append(&record(spec, i)).unwrap();
    }
    w.resume_point()
}

fn reference(name: &str, variant: Variant) -> (std::path::PathBuf, datasets::DatasetSpec) {
    let dir = tmpdir(name);
    let spec = spec(DatasetKind::Failures, variant);
    write(&dir, &spec, N, tiny());
    (dir, spec)
}

#[test]
fn same_input_gives_the_same_bytes_and_resumed_runs_match() {
    let (a, spec) = reference("ref-a", Variant::Full);
    let b = tmpdir("ref-b");
    write(&b, &spec, N, tiny());
    assert_same(&a, &b);
    for crash in [1, 5, 9] {
        let c = tmpdir(&format!("crash-{crash}"));
        let p = crash_after(&c, &spec, crash, "vb dataset generate --test");
        assert!(p.episodes <= crash);
        // Only completed files count: the writer's own account and a reopened one agree.
        let w = DatasetWriter::open_with(&c, &spec, "vb dataset generate --test --resume", tiny())
            .unwrap();
        let q = w.resume_point();
        assert_eq!(q, p, "resume point after a crash at {crash}");
        assert_eq!(
            q.frames,
            (0..q.episodes).map(|i| len(i) as u64).sum::<u64>()
        );
        assert!((q.simulated_seconds - q.frames as f64 / FPS).abs() < 1e-9);
        drop(w);
        let report = datasets::validate(&c).unwrap();
        assert!(
            !report.complete
                && report
                    .problems
                    .iter()
                    .all(|p| p.field.as_deref() == Some("vertibench.complete")),
            "{report}"
        );
        // The resumed run's command line differs: the dataset keeps the one it was started with.
        let mut w =
            DatasetWriter::open_with(&c, &spec, "vb dataset generate --test --resume", tiny())
                .unwrap();
        for i in w.resume_point().episodes..N {
            w.append(&record(&spec, i)).unwrap();
        }
        let s = w.finish().unwrap();
        assert_eq!(s.resumed_from, q);
        assert_same(&a, &c);
        std::fs::remove_dir_all(&c).unwrap();
    }
    // A finished dataset reopens complete and finishes to the same bytes.
    let w = DatasetWriter::open_with(&b, &spec, "other", tiny()).unwrap();
    assert_eq!(w.resume_point().episodes, N);
    w.finish().unwrap();
    assert_same(&a, &b);
    for d in [a, b] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn leftovers_of_a_crash_are_cleaned_and_missing_meta_rebuilt() {
    let (a, spec) = reference("left-a", Variant::Lite);
    let c = tmpdir("left-c");
    let p = crash_after(&c, &spec, 7, "vb dataset generate --test");
    assert!(p.episodes > 0 && p.episodes < 7);
    let files = std::fs::read_dir(c.join("data/chunk-000")).unwrap().count()
        + std::fs::read_dir(c.join("data/chunk-001")).map_or(0, |d| d.count());
    // A crash while writing: temporary files, and the next data file renamed but not its episode metadata.
    let next = datasets::layout::FileId::nth(files as u64, 2);
    std::fs::create_dir_all(c.join(next.data()).parent().unwrap()).unwrap();
    std::fs::copy(a.join(next.data()), c.join(next.data())).unwrap();
    std::fs::write(c.join("data/chunk-000/.file-009.parquet.tmp"), b"PAR1 half").unwrap();
    std::fs::write(c.join("meta/.info.json.tmp"), b"{\"codebase").unwrap();
    // And the meta files lost.
    for f in ["meta/info.json", "meta/stats.json", "meta/tasks.parquet"] {
        std::fs::remove_file(c.join(f)).unwrap();
    }
    let report = datasets::validate(&c).unwrap();
    assert!(!report.is_ok());
    assert!(
        report
            .problems
            .iter()
            .any(|p| p.file == "data/chunk-000/.file-009.parquet.tmp"),
        "{report}"
    );
    assert!(
        report.problems.iter().any(|p| p.file == next.episodes()),
        "{report}"
    );
    let mut w = DatasetWriter::open_with(&c, &spec, "vb dataset generate --test", tiny()).unwrap();
    assert_eq!(w.resume_point(), p, "the orphan data file does not count");
    assert!(!c.join("data/chunk-000/.file-009.parquet.tmp").exists());
    assert!(
        !c.join(next.data()).exists(),
        "the orphan data file is removed"
    );
    assert!(c.join("meta/info.json").is_file(), "meta rebuilt at open");
    for i in w.resume_point().episodes..N {
        w.append(&record(&spec, i)).unwrap();
    }
    w.finish().unwrap();
    assert_same(&a, &c);

    // A finished dataset whose last episode metadata file is lost: that file's episodes are written again.
    let last = std::fs::read_dir(c.join("meta/episodes")).unwrap().count() as u64;
    let mut files: Vec<_> = Vec::new();
    for k in 0.. {
        let id = datasets::layout::FileId::nth(k, 2);
        if !c.join(id.data()).exists() {
            break;
        }
        files.push(id);
    }
    assert!(last >= 2);
    let lost = *files.last().unwrap();
    std::fs::remove_file(c.join(lost.episodes())).unwrap();
    let err = DatasetWriter::open_with(&c, &spec, "x", tiny())
        .err()
        .expect("info.json counts more episodes");
    assert!(err.to_string().contains("files are missing"), "{err}");
    std::fs::remove_file(c.join("meta/info.json")).unwrap();
    write(&c, &spec, N, tiny());
    assert_same(&a, &c);
    for d in [a, c] {
        std::fs::remove_dir_all(d).unwrap();
    }
}

#[test]
fn another_dataset_or_foreign_files_are_refused() {
    let (a, spec) = reference("other-a", Variant::Lite);
    let mut other = spec.clone();
    other.seed = 43;
    other.vehicle = "other-rover".into();
    let err = DatasetWriter::open_with(&a, &other, "x", tiny())
        .err()
        .unwrap();
    let msg = err.to_string();
    assert!(matches!(err, DatasetError::OtherDataset { .. }), "{msg}");
    assert!(
        msg.contains("`seed`: 42 there, 43 here") && msg.contains("`vehicle`"),
        "{msg}"
    );
    assert!(!msg.contains("`kind`"), "only differing fields: {msg}");
    let mut opts = tiny();
    opts.chunks_size = 5;
    let msg = DatasetWriter::open_with(&a, &spec, "x", opts)
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("`chunks_size`: 2 there, 5 here"), "{msg}");
    // Without meta/info.json the files' footers still say what the dataset is.
    std::fs::remove_file(a.join("meta/info.json")).unwrap();
    let msg = DatasetWriter::open_with(&a, &other, "x", tiny())
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("`seed`"), "{msg}");

    let d = tmpdir("foreign");
    std::fs::create_dir_all(d.join("photos")).unwrap();
    std::fs::write(d.join("notes.txt"), b"mine").unwrap();
    std::fs::write(d.join(".hidden"), b"ignored").unwrap();
    let err = DatasetWriter::open(&d, &spec, "x").err().unwrap();
    assert!(matches!(err, DatasetError::NotADataset { .. }));
    assert!(err.to_string().contains("notes.txt, photos"), "{err}");
    assert!(
        !d.join("meta").exists(),
        "nothing written into a foreign directory"
    );

    // A gap in the files (a data file deleted) is damage, not a crash: refused, naming the files.
    let g = tmpdir("gap");
    crash_after(&g, &spec, 10, "x");
    std::fs::remove_file(g.join("data/chunk-000/file-001.parquet")).unwrap();
    let msg = DatasetWriter::open_with(&g, &spec, "x", tiny())
        .err()
        .unwrap()
        .to_string();
    assert!(msg.contains("data/chunk-000/file-001.parquet"), "{msg}");
    for x in [a, d, g] {
        std::fs::remove_dir_all(x).unwrap();
    }
}

#[test]
fn bad_records_are_refused_and_the_writer_goes_on() {
    let d = tmpdir("bad-records");
    let spec = spec(DatasetKind::Expert, Variant::Lite);
    let mut w = DatasetWriter::open_with(&d, &spec, "x", tiny()).unwrap();
    let mut r = record(&spec, 0);
    r.frames.wheels.pop();
    let e = w.append(&r).err().unwrap().to_string();
    assert_eq!(e, "episode 0: field `wheels`: 319 values, expected 320");
    let mut r = record(&spec, 0);
    r.frames.state[3][4] = f64::NAN;
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("field `state`: value 49 is NaN"));
    let mut r = record(&spec, 0);
    r.meta.final_state[14] = f64::INFINITY;
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("field `final_state`: value 14 is inf"));
    let mut r = record(&spec, 0);
    r.meta.final_goal[0] = f64::NAN;
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("field `final_goal`: value 0 is NaN"));
    let mut r = record(&spec, 0);
    r.frames.elevation = Some(vec![0.0; 36 * r.frames.len()]);
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("lite dataset"));
    let mut r = record(&spec, 0);
    r.meta.kind = DatasetKind::Random;
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("field `kind`"));
    let mut r = record(&spec, 0);
    r.frames = Default::default();
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("no frames"));
    for i in 0..3 {
        w.append(&record(&spec, i)).unwrap();
    }
    assert_eq!(w.finish().unwrap().episodes, 3);
    assert!(datasets::validate(&d).unwrap().is_ok());
    let full = self::spec(DatasetKind::Expert, Variant::Full);
    let f = tmpdir("bad-crops");
    let mut w = DatasetWriter::open(&f, &full, "x").unwrap();
    let mut r = record(&full, 0);
    r.frames.semantics.as_mut().unwrap()[7] = 70000.0;
    assert!(w
        .append(&r)
        .err()
        .unwrap()
        .to_string()
        .contains("float16's range"));
    let mut bad = full.clone();
    bad.wheels = 0;
    assert!(DatasetWriter::open(&tmpdir("bad-spec"), &bad, "x")
        .err()
        .unwrap()
        .to_string()
        .contains("`wheels`"));
    for x in [d, f] {
        std::fs::remove_dir_all(x).unwrap();
    }
}

/// A full disk: the temporary data file is `/dev/full`, so writing it fails with ENOSPC (as root too).
#[test]
fn a_full_disk_is_a_clear_error_and_the_dataset_resumes() {
    if !Path::new("/dev/full").exists() {
        eprintln!("skipped: no /dev/full on this system");
        return;
    }
    let (a, spec) = reference("full-a", Variant::Lite);
    let d = tmpdir("full-disk");
    let mut w = DatasetWriter::open_with(&d, &spec, "vb dataset generate --test", tiny()).unwrap();
    std::fs::create_dir_all(d.join("data/chunk-000")).unwrap();
    let tmp = d.join("data/chunk-000/.file-000.parquet.tmp");
    std::os::unix::fs::symlink("/dev/full", &tmp).unwrap();
    let err = (0..N)
        .find_map(|i| w.append(&record(&spec, i)).err())
        .expect("the first data file fails");
    let msg = err.to_string();
    assert!(matches!(err, DatasetError::Io { .. }), "{msg}");
    assert!(
        msg.contains(".file-000.parquet.tmp") && msg.contains("No space left on device"),
        "{msg}"
    );
    let again = w.append(&record(&spec, 5)).err().unwrap().to_string();
    assert!(again.contains("an earlier write failed"), "{again}");
    assert!(w.finish().is_err());
    let report = datasets::validate(&d).unwrap();
    assert!(!report.complete, "{report}");
    assert!(
        report.to_string().contains("vertibench.complete"),
        "{report}"
    );
    let _ = std::fs::remove_file(&tmp);
    write(&d, &spec, N, tiny());
    assert_same(&a, &d);
    for x in [a, d] {
        std::fs::remove_dir_all(x).unwrap();
    }
}

/// No permission: a read-only data directory. Root writes into it anyway, so the test is skipped there (the
/// full-disk test above covers IO errors as root).
#[test]
fn a_read_only_directory_is_a_clear_error() {
    use std::os::unix::fs::PermissionsExt;
    let spec = spec(DatasetKind::Expert, Variant::Lite);
    let d = tmpdir("read-only");
    crash_after(&d, &spec, 4, "x");
    let data = d.join("data/chunk-000");
    std::fs::set_permissions(&data, std::fs::Permissions::from_mode(0o555)).unwrap();
    let probe = data.join("probe");
    if std::fs::write(&probe, b"x").is_ok() {
        let _ = std::fs::remove_file(&probe);
        std::fs::set_permissions(&data, std::fs::Permissions::from_mode(0o755)).unwrap();
        std::fs::remove_dir_all(&d).unwrap();
        eprintln!("skipped: running as root, a read-only directory is writable (the /dev/full test covers IO errors)");
        return;
    }
    let mut w = DatasetWriter::open_with(&d, &spec, "x", WriterOptions { ..tiny() }).unwrap();
    let from = w.resume_point().episodes;
    let err = (from..N)
        .find_map(|i| w.append(&record(&spec, i)).err())
        .expect("a write into data/chunk-000 fails");
    let msg = err.to_string();
    std::fs::set_permissions(&data, std::fs::Permissions::from_mode(0o755)).unwrap();
    assert!(
        msg.contains("data/chunk-000") && msg.contains("ermission denied"),
        "{msg}"
    );
    assert!(!datasets::validate(&d).unwrap().complete);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_garbage_info_json_is_named_and_removing_it_resumes() {
    let (a, spec) = reference("garbage-info-a", Variant::Lite);
    let c = tmpdir("garbage-info-c");
    crash_after(&c, &spec, 6, "vb dataset generate --test");
    std::fs::write(c.join("meta/info.json"), b"\x00\x01 not json").unwrap();
    let msg = DatasetWriter::open_with(&c, &spec, "x", tiny())
        .err()
        .unwrap()
        .to_string();
    assert!(
        msg.contains("meta/info.json: invalid JSON") && msg.contains("remove it to rebuild it"),
        "{msg}"
    );
    std::fs::remove_file(c.join("meta/info.json")).unwrap();
    write(&c, &spec, N, tiny());
    assert_same(&a, &c);
    for d in [a, c] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
