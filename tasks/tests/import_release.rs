//! The importer on the original release's sampled worlds. Needs `VB_RELEASE_DIR` (CI sets it); skipped otherwise.

use sim_core::world::{Semantic, Surface};
use std::path::PathBuf;

fn release() -> Option<PathBuf> {
    match std::env::var_os("VB_RELEASE_DIR") {
        Some(p) => Some(PathBuf::from(p).join("BenchMaps/sampled_maps")),
        None => {
            eprintln!("SKIPPED: VB_RELEASE_DIR is not set, so the importer was not tested on the release's worlds");
            None
        }
    }
}

#[test]
fn imports_the_ten_sampled_worlds_keeping_heights_classes_friction_obstacles_and_tasks() {
    let Some(root) = release() else { return };
    let worlds = tasks::import::discover(&root).unwrap();
    assert_eq!(
        worlds.iter().map(|w| w.id).collect::<Vec<_>>(),
        vec![1, 3, 5, 9, 61, 62, 66, 91, 93, 96]
    );
    for w in &worlds {
        let r = tasks::import::import_world(w).unwrap();
        let text = std::fs::read_to_string(&w.config).unwrap();
        let cfg: serde_json::Value = serde_norway::from_str(&text).unwrap();
        // Heights: gray / 255 * max_height; the BMP's top-left pixel is the north-west corner.
        let bmp = image::open(&w.bmp).unwrap().to_luma8();
        let max_h = cfg["terrain"]["max_height"].as_f64().unwrap();
        let nw = r.world.heightmap.at(0, 128);
        assert!((nw - bmp.get_pixel(0, 0)[0] as f64 / 255.0 * max_h).abs() < 1e-4);
        // Patches: class and friction of texture index [i, j] land at our (15 - i, j).
        for t in cfg["textures"].as_array().unwrap() {
            let (i, j) = (
                t["index"][0].as_u64().unwrap() as usize,
                t["index"][1].as_u64().unwrap() as usize,
            );
            let p = r.world.patches[(15 - i) * 16 + j];
            assert_eq!(p.semantic.as_str(), t["terrain_type"].as_str().unwrap());
            match (p.surface, t.get("friction").and_then(|f| f.as_f64())) {
                (Surface::Rigid { friction }, Some(f)) => assert_eq!(friction, f),
                (Surface::Deformable { soil }, _) => assert_eq!(Some(soil), p.semantic.soil()),
                other => panic!("world {}: unexpected patch {other:?}", w.id),
            }
        }
        let rocks = cfg["obstacles"]["rocks"].as_array().map_or(0, |a| a.len());
        let trees = cfg["obstacles"]["trees"].as_array().map_or(0, |a| a.len());
        assert_eq!(r.world.obstacles.len(), rocks + trees);
        assert_eq!(r.tasks.len(), 10);
        let p0 = &cfg["positions"][3];
        assert_eq!(
            r.tasks[3].start,
            [
                p0["start"][0].as_f64().unwrap(),
                p0["start"][1].as_f64().unwrap()
            ]
        );
        assert!(r.tasks.iter().all(|t| t.path.len() >= 2));
        let _ = Semantic::ALL;
    }
    // The whole directory converts and loads back.
    let out = std::env::temp_dir().join(format!("vb-import-{}", std::process::id()));
    let m = tasks::cli::import_release(&root, &out).unwrap();
    assert_eq!(m.worlds.len(), 10);
    let set = tasks::TaskSet::load(&out).unwrap();
    assert_eq!(set.tasks(61, 1.0).unwrap().len(), 10);
    std::fs::remove_dir_all(&out).unwrap();
}
