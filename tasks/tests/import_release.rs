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

#[test]
fn release_tasks_start_on_the_plane_under_the_footprint_not_on_single_samples() {
    // Issue 13: the old placement took roll and pitch from four single height samples, so one sample in a pit
    // started a task tilted (21 of the release's 1000 tasks more than 30 degrees, one at 57). Now the pose comes from
    // a plane fitted over the footprint and the vehicle settles onto the ground (tilting quasi-statically onto the
    // wheels' actual support, up to about 8 degrees off the plane on these worlds). On all 100 tasks of the 10
    // sampled worlds, every start whose footprint plane is tilted less than 25 degrees settles less than 30 degrees
    // tilted; only starts on terrain that steep may start steeper.
    let Some(root) = release() else { return };
    let spec = sim_core::vehicle::vehicle_by_name("hmmwv").unwrap();
    let (mut old_over_30, mut new_over_30, mut worst) = (0, 0, 0.0f64);
    let mut over_30_on_gentle_planes = Vec::new();
    for w in tasks::import::discover(&root).unwrap() {
        let r = tasks::import::import_world(&w).unwrap();
        for t in &r.tasks {
            let yaw = (t.goal[1] - t.start[1]).atan2(t.goal[0] - t.start[0]);
            let sim = sim_core::Simulation::new(&r.world, &spec, t.start[0], t.start[1], yaw);
            // The angle between the chassis' up axis and the vertical, from Cardan roll and pitch.
            let tilt = |(roll, pitch): (f64, f64)| {
                (roll.cos() * pitch.cos())
                    .clamp(-1.0, 1.0)
                    .acos()
                    .to_degrees()
            };
            let st = sim.state();
            let settled = tilt((st.roll, st.pitch));
            let (_, plane) = sim.footprint_plane(t.start[0], t.start[1], yaw);
            let (pr, pp, _) = plane.euler_angles();
            worst = worst.max((settled - tilt((pr, pp))).abs());
            if tilt((pr, pp)) < 25.0 && settled >= 30.0 {
                over_30_on_gentle_planes.push((t.id(), settled));
            }
            // The old placement: pitch and roll from four single samples at the wheelbase and track ends.
            let h = &r.world.heightmap;
            let (l, wd) = (spec.wheelbase(), spec.track());
            let (c, s) = (yaw.cos(), yaw.sin());
            let (x, y) = (t.start[0], t.start[1]);
            let pitch = ((h.height_bilinear(x + c * l / 2.0, y + s * l / 2.0)
                - h.height_bilinear(x - c * l / 2.0, y - s * l / 2.0))
                / l)
                .atan();
            let roll = ((h.height_bilinear(x - s * wd / 2.0, y + c * wd / 2.0)
                - h.height_bilinear(x + s * wd / 2.0, y - c * wd / 2.0))
                / wd)
                .atan();
            let old = tilt((roll, pitch));
            old_over_30 += usize::from(old > 30.0);
            new_over_30 += usize::from(settled > 30.0);
        }
    }
    eprintln!(
        "starts tilted more than 30 degrees: {old_over_30} with four samples, {new_over_30} settled on the fitted \
         plane; largest difference between the settled tilt and the plane's {worst:.2} deg"
    );
    assert!(
        over_30_on_gentle_planes.is_empty(),
        "starts tilted past 30 degrees on gentle planes: {over_30_on_gentle_planes:?}"
    );
    assert!(new_over_30 <= old_over_30);
}
