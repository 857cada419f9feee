//! A task set whose numbers are out of any physical range is refused when it is opened, with the file and field,
//! even when its manifest's version is consistent with the edited files (as a hand-edited set's author would make it).

use serde_json::{json, Value};
use std::path::{Path, PathBuf};
use tasks::format::{content_version, Manifest};
use tasks::TaskSet;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vb-range-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("worlds")).unwrap();
    dir
}

/// Copies the committed set's world 3 into `dir`, edits its JSON with `edit` and seals a consistent manifest.
fn edited_set(dir: &Path, edit: impl Fn(&mut Value)) {
    let src = TaskSet::default_dir().join("worlds");
    std::fs::copy(src.join("003.png"), dir.join("worlds/003.png")).unwrap();
    let mut v: Value =
        serde_json::from_str(&std::fs::read_to_string(src.join("003.json")).unwrap()).unwrap();
    edit(&mut v);
    std::fs::write(
        dir.join("worlds/003.json"),
        serde_json::to_string(&v).unwrap(),
    )
    .unwrap();
    let text = std::fs::read_to_string(TaskSet::default_dir().join("manifest.json")).unwrap();
    let mut m: Manifest = serde_json::from_str(&text).unwrap();
    m.worlds.retain(|w| w.id == 3);
    m.version = content_version(dir, &m).unwrap();
    std::fs::write(
        dir.join("manifest.json"),
        serde_json::to_string(&m).unwrap(),
    )
    .unwrap();
}

fn first_rigid(v: &mut Value) -> &mut Value {
    v["patches"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|p| p.get("friction").is_some())
        .unwrap()
}

#[test]
fn out_of_range_numbers_are_refused_on_load_with_file_and_field() {
    type Edit = Box<dyn Fn(&mut Value)>;
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "heights",
            Box::new(|v| v["height_max"] = json!(1e300)),
            "`height_max`",
        ),
        (
            "low",
            Box::new(|v| v["height_min"] = json!(-1e12)),
            "`height_min`",
        ),
        (
            "inverted",
            Box::new(|v| v["height_max"] = json!(-1.0)),
            "`height_max`",
        ),
        ("cell", Box::new(|v| v["cell"] = json!(1e9)), "`cell`"),
        ("cell0", Box::new(|v| v["cell"] = json!(0.0)), "`cell`"),
        (
            "friction",
            Box::new(|v| first_rigid(v)["friction"] = json!(1e300)),
            "].friction`",
        ),
        (
            "obstacle-x",
            Box::new(|v| v["obstacles"][0]["x"] = json!(1e300)),
            "`obstacles[0].x`",
        ),
        (
            "obstacle-z",
            Box::new(|v| v["obstacles"][0]["z"] = json!(-1e300)),
            "`obstacles[0].z`",
        ),
        (
            "obstacle-yaw",
            Box::new(|v| v["obstacles"][0]["yaw"] = json!(1e300)),
            "`obstacles[0].yaw`",
        ),
        (
            "obstacle-size",
            Box::new(|v| v["obstacles"][0]["half_extents"][2] = json!(1e300)),
            "`obstacles[0].half_extents[2]`",
        ),
        (
            "obstacle-negative",
            Box::new(|v| v["obstacles"][0]["half_extents"][0] = json!(-1.0)),
            "`obstacles[0].half_extents[0]`",
        ),
        (
            "start",
            Box::new(|v| v["tasks"][2]["start"] = json!([1e300, 0.0])),
            "`tasks[2].start`",
        ),
        (
            "goal",
            Box::new(|v| v["tasks"][0]["goal"] = json!([0.0, -65])),
            "`tasks[0].goal`",
        ),
        (
            "path",
            Box::new(|v| v["tasks"][1]["path"][1] = json!([0.0, 1e300])),
            "`tasks[1].path[1]`",
        ),
    ];
    for (name, edit, field) in cases {
        let dir = scratch(name);
        edited_set(&dir, edit);
        let e = TaskSet::load(&dir).map(|_| ()).expect_err(name).to_string();
        assert!(e.contains("003.json") && e.contains(field), "{name}: {e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn an_unedited_copy_loads() {
    // The helper itself makes a loadable set: the refusals above are the edits', not the copy's.
    let dir = scratch("plain");
    edited_set(&dir, |_| {});
    let set = TaskSet::load(&dir).unwrap();
    let world = set.world(3, 1.0).unwrap();
    assert!(world.heightmap.heights.iter().all(|h| h.is_finite()));
    std::fs::remove_dir_all(&dir).unwrap();
}
