//! Architecture invariants that a reviewer would otherwise have to remember (see ARCHITECTURE.md).
//!
//! - sim-core depends on no service crate and on nothing that does IO, async or wall-clock time.
//! - sim-core's sources use no wall clock, no unseeded RNG, no filesystem or network, no hash-ordered containers.

use std::path::{Path, PathBuf};

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
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
                // `name.workspace = true` names the crate `name`.
                let name = name.trim();
                deps.push(name.strip_suffix(".workspace").unwrap_or(name).to_string());
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
    // The perception layer keeps the same rules: its noise is part of a run's identity.
    let mut files = Vec::new();
    rust_files(&repo_root().join("sim-core/src"), &mut files);
    assert!(files.len() >= 3, "sim-core sources not found");
    let before = files.len();
    rust_files(&repo_root().join("perception/src"), &mut files);
    assert!(files.len() >= before + 3, "perception sources not found");
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

/// ARCHITECTURE.md: the vehicle never imports `planner` (issue 60: `vehicle/dynamics.rs` did).
#[test]
fn the_vehicle_never_imports_the_planner_module() {
    let mut files = Vec::new();
    rust_files(&repo_root().join("sim-core/src/vehicle"), &mut files);
    assert!(files.len() >= 3, "sim-core's vehicle sources not found");
    let mut violations = Vec::new();
    for file in &files {
        let text = std::fs::read_to_string(file).unwrap();
        for (no, line) in text.lines().enumerate() {
            let code = line.split("//").next().unwrap_or("");
            if code.contains("crate::planner") || code.contains("planner::") {
                violations.push(format!("{}:{}", file.display(), no + 1));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "the vehicle imports the planner module:\n{}",
        violations.join("\n")
    );
}

fn deps_of(crate_dir: &str) -> Vec<String> {
    let manifest = std::fs::read_to_string(repo_root().join(crate_dir).join("Cargo.toml"))
        .unwrap_or_else(|e| panic!("{crate_dir}/Cargo.toml: {e}"));
    normal_dependencies(&manifest)
}

/// Workers never touch the database; only the coordinator writes it; the leaderboard reads it.
#[test]
fn only_the_coordinator_writes_the_store_and_workers_never_touch_it() {
    for dir in [
        "services/vb-worker",
        "cli/vb-submit",
        "examples/example-planner",
    ] {
        let deps = deps_of(dir);
        for forbidden in ["sqlx", "vb-store", "vb-coordinator"] {
            assert!(
                !deps.iter().any(|d| d == forbidden),
                "{dir} must not depend on {forbidden}"
            );
        }
    }
    // The leaderboard holds only a `Reader` (it has no way to write).
    let mut files = Vec::new();
    rust_files(&repo_root().join("services/vb-leaderboard/src"), &mut files);
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        for needle in [
            "Store::open",
            "vb_store::Store",
            "use vb_store::{Store",
            ", Store,",
            ", Store}",
        ] {
            assert!(
                !text.contains(needle),
                "{} uses the writing store (`{needle}`)",
                f.display()
            );
        }
    }
}

/// Generated protobuf types stay at the service edge: no library below the services depends on them.
#[test]
fn protobuf_types_stay_at_the_service_edge() {
    for dir in [
        "sim-core",
        "perception",
        "tasks",
        "swae",
        "planners/baselines",
        "eval",
        "services/vb-store",
        "services/vb-leaderboard",
    ] {
        let deps = deps_of(dir);
        for forbidden in ["vb-proto", "tonic", "prost"] {
            assert!(
                !deps.iter().any(|d| d == forbidden),
                "{dir} must not depend on {forbidden}"
            );
        }
    }
    // The example planner is the shape a user copies: it depends on the protocol only, not on our service code.
    let deps = deps_of("examples/example-planner");
    for d in &deps {
        assert!(
            !d.starts_with("vb-") || d == "vb-proto",
            "the example planner depends on {d}"
        );
        assert!(
            !["sim-core", "tasks", "baselines", "eval"].contains(&d.as_str()),
            "the example planner depends on {d}"
        );
    }
}

/// The task set does not depend on the terrain model (the dependency points from `swae` to `tasks`), and the
/// deterministic decoder used for generation does not touch candle.
#[test]
fn tasks_do_not_depend_on_the_terrain_model_and_generation_avoids_candle() {
    let deps = deps_of("tasks");
    for forbidden in ["swae", "candle-core", "candle-nn"] {
        assert!(
            !deps.iter().any(|d| d == forbidden),
            "tasks must not depend on {forbidden}"
        );
    }
    for file in ["decoder/mod.rs", "decoder/ops.rs", "source.rs"] {
        let text = std::fs::read_to_string(repo_root().join("swae/src").join(file)).unwrap();
        for used in ["candle_core", "candle_nn", "rayon"] {
            assert!(!text.contains(used), "swae/src/{file} must not use {used}");
        }
    }
}
