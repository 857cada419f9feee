//! The generator tests' training set (seed 7, worlds 1, 10 and 19: low relief, sparse obstacles, rigid,
//! deformable and mixed ground) and configuration.
#![allow(dead_code)]

use datasets::generate::GenerateConfig;
use datasets::DatasetKind;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use tasks::generate::HeightSource;

/// Period of a frame at 20 Hz for the HMMWV (13 physics steps of 4 ms).
pub const PERIOD: f64 = 0.052;

/// Directory name of a test process's training set (plus its id).
const PREFIX: &str = "datasets-generate-";

pub fn training_set() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let tmp = Path::new(env!("CARGO_TARGET_TMPDIR"));
        // Sets of earlier runs whose process is gone are removed.
        for e in std::fs::read_dir(tmp).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if let Some(pid) = name.strip_prefix(PREFIX) {
                if !Path::new("/proc").join(pid).exists() {
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
        }
        let dir = tmp.join(format!("{PREFIX}{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let source = swae::SwaeSource::committed().expect("committed weights");
        let records = tasks::generate::generate(7, &[1, 10, 19], &source).expect("generation");
        tasks::format::save(&dir, Some(7), &source.name(), &records).expect("save");
        dir
    })
}

/// A run of `kind` on the training set: seed 11, 12 s random episodes, two threads.
pub fn config(kind: DatasetKind, hours: f64) -> GenerateConfig {
    let mut cfg = GenerateConfig::new(kind, training_set(), hours);
    cfg.seed = 11;
    cfg.max_time = 12.0;
    cfg.threads = 2;
    cfg
}
