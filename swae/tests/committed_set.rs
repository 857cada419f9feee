//! The committed task set v4 (tasks/data/v4) is the SWAE set of the committed weights and calibration: it
//! regenerates byte for byte (on any thread), its surface counterfactuals change only the ground, and sets made with
//! other seeds share no world with it; set v3 still regenerates from the v3 weights and calibration. (Properties that do not depend on the height source are tested in crate
//! `tasks`, tests/task_set.rs.)

use sim_core::world::SemanticsKind;
use std::path::Path;
use swae::SwaeSource;
use tasks::format::WorldRecord;
use tasks::generate::HeightSource;
use tasks::TaskSet;

fn records() -> Vec<WorldRecord> {
    TaskSet::committed().unwrap().records().unwrap()
}

#[test]
fn the_committed_set_is_the_swae_set() {
    let set = TaskSet::committed().unwrap();
    assert_eq!(
        set.manifest.generator,
        SwaeSource::committed().unwrap().name()
    );
    assert_eq!(set.manifest.seed, Some(tasks::generate::DEFAULT_SEED));
}

#[test]
fn sets_from_other_seeds_share_no_world_with_the_benchmark() {
    // Issue 17 point 4: training sets made with other seeds (`vb tasks generate --seed N`) are held out from the
    // benchmark: no terrain group seed in common, hence no heightmap (compared here sample by sample), patches,
    // obstacles or tasks. A seed whose group seeds would collide is refused.
    use tasks::design::{factors, TERRAIN_GROUPS};
    use tasks::generate::{check_held_out, terrain_seed, DEFAULT_SEED};
    let src = SwaeSource::committed().unwrap();
    let level = |g: u32| {
        (1..=tasks::design::WORLDS)
            .map(factors)
            .find(|f| f.terrain == g)
            .unwrap()
            .level
    };
    let benchmark: Vec<_> = records().into_iter().map(|r| r.world.heightmap).collect();
    for seed in [1, 2, 42, DEFAULT_SEED + 1] {
        check_held_out(seed).unwrap();
        for g in 1..=TERRAIN_GROUPS {
            let h = src.heightmap(terrain_seed(seed, g), level(g)).unwrap();
            assert!(
                benchmark.iter().all(|b| *b != h),
                "seed {seed} group {g} repeats a benchmark world"
            );
        }
    }
    // terrain_seed(m, g) mixes m ^ g * golden: this seed's groups 1 and 2 would be the benchmark's groups 2 and 1.
    const GOLDEN: u64 = 0x9E37_79B9_7F4A_7C15;
    let colliding = DEFAULT_SEED ^ GOLDEN ^ 2u64.wrapping_mul(GOLDEN);
    assert_eq!(terrain_seed(colliding, 2), terrain_seed(DEFAULT_SEED, 1));
    let err = check_held_out(colliding).unwrap_err().to_string();
    assert!(
        err.contains("terrain group 1 would repeat terrain group 2 of the benchmark"),
        "{err}"
    );
    let out = std::env::temp_dir().join(format!("vb-held-out-{}", std::process::id()));
    assert!(tasks::cli::generate_set(&out, colliding, &src).is_err());
    assert!(!out.exists(), "a refused seed writes nothing");
}

#[test]
fn regeneration_is_byte_identical_to_the_committed_set() {
    let committed = TaskSet::committed().unwrap();
    let seed = committed.manifest.seed.expect("generated set has a seed");
    let out = std::env::temp_dir().join(format!("vb-regen-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    // On a spawned thread (the committed set was written on the main thread of `vb tasks generate`): the decoder
    // gives the same bits on any thread and machine.
    let out2 = out.clone();
    let m = std::thread::spawn(move || {
        let src = SwaeSource::committed().unwrap();
        let m = tasks::cli::generate_set(&out2, seed, &src).unwrap();
        assert_eq!(m.generator, src.name());
        m
    })
    .join()
    .unwrap();
    assert_eq!(m, committed.manifest);
    let files = |dir: &Path| {
        let mut v: Vec<_> = std::fs::read_dir(dir.join("worlds"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        v.sort();
        v
    };
    let (a, b) = (files(&TaskSet::default_dir()), files(&out));
    assert_eq!(a.len(), b.len());
    for (x, y) in a.iter().zip(&b) {
        assert_eq!(
            std::fs::read(x).unwrap(),
            std::fs::read(y).unwrap(),
            "{} differs",
            x.display()
        );
    }
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn a_surface_counterfactual_changes_only_the_ground() {
    let committed = TaskSet::committed().unwrap();
    let seed = committed.manifest.seed.expect("generated set has a seed");
    let base = records();
    let out = std::env::temp_dir().join(format!("vb-surface-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let kind = SemanticsKind::Deformable;
    let m = tasks::cli::generate_set_with_surface(
        &out,
        seed,
        &SwaeSource::committed().unwrap(),
        Some(kind),
    )
    .unwrap();
    assert_eq!(
        m.generator,
        format!("{} surface=deformable", committed.manifest.generator)
    );
    assert_ne!(m.version, committed.manifest.version);
    let cf = TaskSet::load(&out).unwrap();
    let s = tasks::cli::stats(&cf).unwrap();
    assert_eq!(s.by_semantics.get("deformable"), Some(&100), "{s:?}");
    let cf_records = cf.records().unwrap();
    assert_eq!(cf_records.len(), base.len());
    let mut changed = 0;
    for (a, b) in base.iter().zip(&cf_records) {
        let id = a.world.id;
        assert_eq!(b.world.id, id);
        // Heights, obstacles, tasks and paths are those of the benchmark's world ...
        assert_eq!(a.world.heightmap, b.world.heightmap, "world {id}");
        assert_eq!(a.world.obstacles, b.world.obstacles, "world {id}");
        assert_eq!(a.tasks, b.tasks, "world {id}");
        assert_eq!(
            (a.world.level, a.world.density, a.terrain),
            (b.world.level, b.world.density, b.terrain)
        );
        // ... and the ground is deformable everywhere.
        assert_eq!(b.world.semantics, kind);
        assert!(b.world.patches.iter().all(|p| p.semantic.is_deformable()));
        if a.world.semantics != kind {
            assert_ne!(a.world.patches, b.world.patches, "world {id}");
        }
        changed += usize::from(a.world.patches != b.world.patches);
    }
    // Rigid and mixed worlds all change; a deformable world keeps its patches only by chance (both draws one and
    // the same soil class, whose patches carry no per-patch friction): 3 of the 33 here, one terrain group.
    assert!(changed >= 67 + 30, "{changed} worlds changed");
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn the_v3_weights_still_regenerate_set_v3() {
    // Set v3 (SWAE v3's stationary texture at 11.32 m; results of 2026-11-24) left the repository when v4 replaced
    // it; its version hash covers every world file, so `vb tasks generate --weights
    // swae/weights/swae-v3.safetensors --full-scale 11.32` rebuilds it byte for byte: the v3 weights have no
    // `detail.amplitude`, so their texture is drawn exactly as before.
    let weights = Path::new(env!("CARGO_MANIFEST_DIR")).join("weights/swae-v3.safetensors");
    let src = SwaeSource::from_file(&weights, swae::source::V3_FULL_SCALE_HEIGHT).unwrap();
    let out = std::env::temp_dir().join(format!("vb-regen-v3-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let m = tasks::cli::generate_set(&out, tasks::generate::DEFAULT_SEED, &src).unwrap();
    assert_eq!(m.version, "bf02f5d2a56c624c");
    std::fs::remove_dir_all(&out).unwrap();
}
