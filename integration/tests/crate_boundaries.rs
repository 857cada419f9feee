//! Crate boundaries over transitive dependencies (issue 16): what each service crate links, as Cargo resolves it.
//!
//! `cargo tree -p CRATE` resolves one package with its own features, as a user building only that package gets it;
//! `cargo metadata`'s resolve unifies the features of the whole workspace (where `vb` asks for `vb-submit`'s
//! `validate`), so it is used for the declared minimum Rust versions, and `cargo tree` for the boundaries.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .canonicalize()
        .unwrap()
}

fn cargo() -> Command {
    let mut c = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    c.current_dir(repo_root());
    c
}

/// The host's target triple, as `rustc -vV` names it.
fn host_triple() -> String {
    let out = Command::new(std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into()))
        .arg("-vV")
        .output()
        .expect("running rustc -vV");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .find_map(|l| l.strip_prefix("host: "))
        .expect("rustc -vV names the host")
        .trim()
        .to_string()
}

/// `cargo metadata` of the workspace with `args`, parsed.
fn metadata(args: &[&str]) -> serde_json::Value {
    let out = cargo()
        .args(["metadata", "--offline", "--format-version", "1"])
        .args(args)
        .output()
        .expect("running cargo metadata");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("metadata JSON")
}

/// Every package `package` links (normal dependencies, transitively, itself included) with `features`.
fn linked(package: &str, features: &[&str]) -> BTreeSet<String> {
    let mut c = cargo();
    c.args([
        "tree",
        "--offline",
        "-e",
        "normal",
        "--prefix",
        "none",
        "--format",
        "{p}",
        "-p",
        package,
    ]);
    // `--no-default-features` passes as a flag; the rest are features.
    let (flags, features): (Vec<&str>, Vec<&str>) =
        features.iter().partition(|f| f.starts_with("--"));
    c.args(flags);
    if !features.is_empty() {
        c.args(["--features", &features.join(",")]);
    }
    let out = c.output().expect("running cargo tree");
    assert!(
        out.status.success(),
        "cargo tree -p {package}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

fn assert_links_none(package: &str, features: &[&str], forbidden: &[&str]) {
    let deps = linked(package, features);
    assert!(
        deps.contains(package),
        "cargo tree -p {package} printed nothing useful: {deps:?}"
    );
    for f in forbidden {
        assert!(!deps.contains(*f), "{package} {features:?} links {f}");
    }
}

#[test]
fn the_coordinator_links_neither_parquet_nor_rayon() {
    assert_links_none(
        "vb-coordinator",
        &[],
        &["parquet", "rayon", "eval", "candle-core"],
    );
    // Nor do the store and the leaderboard (they read and write results through `results` without Parquet).
    for p in ["vb-store", "vb-leaderboard"] {
        assert_links_none(p, &[], &["parquet", "rayon", "eval", "candle-core"]);
    }
}

/// The service tier is free of physics (issue 30): the coordinator, the store and the leaderboard read the
/// benchmark through `contracts::Catalog` and results through `results`; the binary that wires them passes in what
/// they need of the task set and the simulator.
#[test]
fn the_service_tier_links_no_physics() {
    for p in ["vb-coordinator", "vb-store", "vb-leaderboard"] {
        assert_links_none(
            p,
            &[],
            &[
                "sim-core",
                "tasks",
                "baselines",
                "learned",
                "safetensors",
                "swae",
                "nalgebra",
                "parry3d-f64",
                "image",
            ],
        );
    }
}

/// Benchmark harnesses live in `service-bench`, not in the product crates they measure.
#[test]
fn benchmark_harnesses_stay_out_of_product_crates() {
    for (dir, harness) in [
        ("services/vb-store/src", "seed.rs"),
        ("services/vb-leaderboard/src", "bench.rs"),
    ] {
        assert!(
            !repo_root().join(dir).join(harness).exists(),
            "{dir}/{harness} is a benchmark harness: it belongs in service-bench"
        );
    }
    assert!(linked("vb", &[]).contains("service-bench"));
}

/// Issue 60: a worker looks its built-in planners up in `registry` (the one lookup) and links no evaluator; the
/// learned planners build on `mppi-core`, as the oracle MPPI-6 does, with no edge between the two planner crates.
#[test]
fn planners_come_from_the_registry_and_share_mppi_core_without_a_sideways_edge() {
    assert!(linked("vb-worker", &[]).contains("registry"));
    assert_links_none("vb-worker", &[], &["eval"]);
    assert_links_none("learned", &[], &["baselines"]);
    assert_links_none("baselines", &[], &["learned"]);
    for p in ["baselines", "learned"] {
        assert!(linked(p, &[]).contains("mppi-core"), "{p}");
    }
}

/// Folder name = crate name, for every member of the workspace.
#[test]
fn every_crate_lives_in_a_folder_of_its_name() {
    let meta = metadata(&["--no-deps"]);
    let packages = meta["packages"].as_array().unwrap();
    assert!(packages.len() >= 18, "{} packages", packages.len());
    for p in packages {
        let name = p["name"].as_str().unwrap();
        let manifest = Path::new(p["manifest_path"].as_str().unwrap());
        let folder = manifest.parent().and_then(|d| d.file_name()).unwrap();
        assert_eq!(folder.to_string_lossy(), name, "{}", manifest.display());
    }
}

#[test]
fn vb_submit_links_the_simulator_only_for_validate() {
    assert_links_none(
        "vb-submit",
        &[],
        &[
            "vb-worker",
            "baselines",
            "sim-core",
            "tasks",
            "rayon",
            "candle-core",
        ],
    );
    let with = linked("vb-submit", &["validate"]);
    for needed in ["vb-worker", "sim-core", "tasks"] {
        assert!(
            with.contains(needed),
            "vb-submit's validate feature does not bring {needed}"
        );
    }
}

/// candle only where the terrain model is trained: `swae`'s `train` feature (on by default in `swae` and `vb`);
/// generation (`swae` without it) and `vb --no-default-features` link none of it.
#[test]
fn candle_is_a_feature_of_the_terrain_model() {
    assert_links_none(
        "swae",
        &["--no-default-features"],
        &["candle-core", "candle-nn"],
    );
    assert_links_none(
        "vb",
        &["--no-default-features"],
        &["candle-core", "candle-nn"],
    );
    assert!(
        linked("swae", &[]).contains("candle-core"),
        "swae's train feature brings candle"
    );
}

#[test]
fn candle_stays_in_the_terrain_model_crate() {
    for p in [
        "contracts",
        "sim-core",
        "tasks",
        "results",
        "eval",
        "baselines",
        "learned",
        "vb-worker",
        "vb-coordinator",
        "vb-store",
        "vb-leaderboard",
        "vb-submit",
        "vb-net",
        // The Python wheel generates task sets with the plain-Rust decoder.
        "vertibench-py",
    ] {
        assert_links_none(p, &[], &["candle-core", "candle-nn"]);
    }
}

/// The servers' connection guard (`vb-net`) is transport only: with both its sides it links no service crate, no
/// store, no simulator and no generated protobuf types; the leaderboard, which uses its HTTP side, links no gRPC.
#[test]
fn the_connection_guard_is_transport_only_and_the_leaderboard_links_no_grpc() {
    assert_links_none(
        "vb-net",
        &["http", "grpc"],
        &[
            "vb-proto",
            "vb-store",
            "vb-coordinator",
            "vb-worker",
            "vb-leaderboard",
            "sim-core",
            "tasks",
            "sqlx-core",
        ],
    );
    assert_links_none("vb-leaderboard", &[], &["tonic", "prost", "vb-proto"]);
    assert!(
        linked("vb-net", &["grpc"]).contains("tonic"),
        "vb-net's grpc feature brings tonic"
    );
}

/// Every crate declares the workspace's minimum Rust version, and it is no lower than any dependency's (the
/// dependencies' declared `rust-version`s are a floor; clippy's `incompatible_msrv` lint, on in CI, refuses our own
/// use of a newer standard-library API).
#[test]
fn every_crate_declares_the_real_minimum_rust_version() {
    // The host's packages only: those are the ones a build here fetches (and `--offline` then finds), and the
    // ones whose `rust-version` bounds ours; other platforms' (Android, Windows) are never downloaded.
    let meta = metadata(&["--filter-platform", &host_triple()]);
    let members: BTreeSet<&str> = meta["workspace_members"]
        .as_array()
        .expect("members")
        .iter()
        .filter_map(|m| m.as_str())
        .collect();
    let version = |v: &str| -> (u32, u32) {
        let mut it = v.split('.').map(|x| x.parse::<u32>().unwrap_or(0));
        (it.next().unwrap_or(0), it.next().unwrap_or(0))
    };
    let mut ours = BTreeSet::new();
    let mut floor = ((0, 0), String::new());
    for p in meta["packages"].as_array().expect("packages") {
        let name = p["name"].as_str().unwrap_or("?");
        let rv = p["rust_version"].as_str();
        if members.contains(p["id"].as_str().unwrap_or("")) {
            let rv = rv.unwrap_or_else(|| panic!("{name} declares no rust-version"));
            ours.insert(version(rv));
        } else if let Some(rv) = rv {
            if version(rv) > floor.0 {
                floor = (version(rv), name.to_string());
            }
        }
    }
    assert_eq!(
        ours.len(),
        1,
        "the crates declare different minimum versions: {ours:?}"
    );
    let declared = *ours.iter().next().unwrap();
    assert!(
        declared >= floor.0,
        "rust-version {declared:?} is below {}'s {:?}",
        floor.1,
        floor.0
    );
}
