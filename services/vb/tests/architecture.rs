//! Architecture invariants that a reviewer would otherwise have to remember (see ARCHITECTURE.md).
//!
//! - sim-core depends on no service crate and on nothing that does IO, async or wall-clock time.
//! - sim-core's sources use no wall clock, no unseeded RNG, no filesystem or network, no hash-ordered containers.

use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap()
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The `[dependencies]` section of a manifest (not dev-dependencies: tests and benches may use more).
fn normal_dependencies(manifest: &str) -> Vec<String> {
    let mut deps = Vec::new();
    let mut in_deps = false;
    for line in manifest.lines() {
        let line = line.trim();
        if line.starts_with('[') {
            in_deps = line == "[dependencies]";
            continue;
        }
        if in_deps && !line.is_empty() && !line.starts_with('#') {
            if let Some((name, _)) = line.split_once('=') {
                deps.push(name.trim().to_string());
            }
        }
    }
    deps
}

#[test]
fn sim_core_has_no_io_async_or_service_dependencies() {
    let manifest = std::fs::read_to_string(repo_root().join("sim-core/Cargo.toml")).unwrap();
    let deps = normal_dependencies(&manifest);
    assert!(!deps.is_empty(), "could not parse sim-core's dependencies");
    let forbidden = [
        "tokio",
        "tonic",
        "prost",
        "sqlx",
        "axum",
        "hyper",
        "reqwest",
        "futures",
        "async-std",
        "tasks",
        "swae",
        "baselines",
        "eval",
        "viz",
        "vb",
        "image",
        "chrono",
        "time",
        "getrandom",
    ];
    for dep in &deps {
        assert!(
            !forbidden.contains(&dep.as_str()),
            "sim-core must not depend on `{dep}`"
        );
    }
}

#[test]
fn sim_core_sources_do_no_io_and_use_no_clock_or_global_rng() {
    let mut files = Vec::new();
    rust_files(&repo_root().join("sim-core/src"), &mut files);
    assert!(files.len() >= 3, "sim-core sources not found");
    let forbidden = [
        "std::fs",
        "std::net",
        "std::time::Instant",
        "SystemTime",
        "Instant::now",
        "thread_rng",
        "from_entropy",
        "OsRng",
        "HashMap",
        "HashSet",
        "std::env",
        "println!",
        "eprintln!",
    ];
    let mut violations = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (no, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            for pat in &forbidden {
                if code.contains(pat) {
                    violations.push(format!("{}:{}: `{pat}`", file.display(), no + 1));
                }
            }
        }
    }
    assert!(
        violations.is_empty(),
        "sim-core invariant violations:\n{}",
        violations.join("\n")
    );
}
