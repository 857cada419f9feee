//! Bad input gets an error naming the file and the field, never a panic.

use std::path::{Path, PathBuf};
use tasks::format::{content_version, Manifest};
use tasks::TaskSet;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("vb-err-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("worlds")).unwrap();
    dir
}

/// Copies the committed set's world `id` into `dir` and seals a manifest listing it alone.
fn copy_world(dir: &Path, id: u32) {
    let src = TaskSet::default_dir().join("worlds");
    for ext in ["json", "png"] {
        std::fs::copy(
            src.join(format!("{id:03}.{ext}")),
            dir.join(format!("worlds/{id:03}.{ext}")),
        )
        .unwrap();
    }
    seal(dir, &[id]);
}

/// Writes a manifest listing worlds `ids` with the version their files in `dir` hash to, as a task set's author
/// would after editing it by hand.
fn seal(dir: &Path, ids: &[u32]) {
    let text = std::fs::read_to_string(TaskSet::default_dir().join("manifest.json")).unwrap();
    let mut m: Manifest = serde_json::from_str(&text).unwrap();
    m.worlds.retain(|w| ids.contains(&w.id));
    // Missing files leave the old version: the load reports the missing file.
    if let Ok(v) = content_version(dir, &m) {
        m.version = v;
    }
    std::fs::write(
        dir.join("manifest.json"),
        serde_json::to_string(&m).unwrap(),
    )
    .unwrap();
}

#[test]
fn missing_and_malformed_manifests_name_the_file() {
    let dir = scratch("manifest");
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(e.contains("manifest.json"), "{e}");
    std::fs::write(dir.join("manifest.json"), "{ not json").unwrap();
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(
        e.contains("manifest.json") && e.contains("invalid JSON"),
        "{e}"
    );
    std::fs::write(
        dir.join("manifest.json"),
        r#"{"format":"other/9","version":"x","seed":1,"generator":"g","worlds":[]}"#,
    )
    .unwrap();
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(e.contains("`format`") && e.contains("other/9"), "{e}");
}

#[test]
fn broken_world_files_name_the_file_and_field() {
    let dir = scratch("world");
    copy_world(&dir, 3);
    let set = TaskSet::load(&dir).unwrap();
    assert!(set.world(3, 1.0).is_ok());
    // A missing world file.
    seal(&dir, &[3, 4]);
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(e.contains("004.json"), "{e}");
    // A rigid patch without friction.
    let json_path = dir.join("worlds/003.json");
    let text = std::fs::read_to_string(&json_path).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let patch = v["patches"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .find(|p| p.get("friction").is_some())
        .unwrap();
    patch.as_object_mut().unwrap().remove("friction");
    std::fs::write(&json_path, serde_json::to_string(&v).unwrap()).unwrap();
    seal(&dir, &[3]);
    // World files' fields are checked when the set is opened.
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(
        e.contains("003.json") && e.contains("friction") && e.contains("missing"),
        "{e}"
    );
    // A wrongly sized heightmap.
    std::fs::write(&json_path, &text).unwrap();
    let img: image::ImageBuffer<image::Luma<u16>, Vec<u16>> = image::ImageBuffer::new(64, 64);
    img.save(dir.join("worlds/003.png")).unwrap();
    seal(&dir, &[3]);
    let e = TaskSet::load(&dir)
        .unwrap()
        .world(3, 1.0)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("003.png") && e.contains("expected 129 x 129"),
        "{e}"
    );
}

#[test]
fn a_task_set_changed_after_it_was_written_is_refused() {
    let dir = scratch("tampered");
    copy_world(&dir, 5);
    let version = TaskSet::load(&dir).unwrap().version().to_string();
    // Obstacles removed and friction raised, the manifest left as it was.
    let json_path = dir.join("worlds/005.json");
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json_path).unwrap()).unwrap();
    v["obstacles"] = serde_json::json!([]);
    for p in v["patches"].as_array_mut().unwrap() {
        if p.get("friction").is_some() {
            p["friction"] = serde_json::json!(2.0);
        }
    }
    std::fs::write(&json_path, serde_json::to_string(&v).unwrap()).unwrap();
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(
        e.contains("manifest.json") && e.contains("`version`") && e.contains(&version),
        "{e}"
    );
    // A made-up version is refused too.
    seal(&dir, &[5]);
    let path = dir.join("manifest.json");
    let text = std::fs::read_to_string(&path).unwrap();
    let sealed: Manifest = serde_json::from_str(&text).unwrap();
    std::fs::write(&path, text.replace(&sealed.version, "0000000000000000")).unwrap();
    let e = TaskSet::load(&dir).unwrap_err().to_string();
    assert!(
        e.contains("0000000000000000") && e.contains(&sealed.version),
        "{e}"
    );
}

#[test]
fn importer_errors_name_the_file_and_field() {
    let root = std::env::temp_dir().join(format!("vb-err-import-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let e = tasks::import::discover(&root).unwrap_err().to_string();
    assert!(e.contains("Configs/Final"), "{e}");
    std::fs::create_dir_all(root.join("Configs/Final")).unwrap();
    std::fs::create_dir_all(root.join("Worlds")).unwrap();
    std::fs::write(
        root.join("Configs/Final/config5_low.yaml"),
        "terrain: [unclosed",
    )
    .unwrap();
    let worlds = tasks::import::discover(&root).unwrap();
    let e = tasks::import::import_world(&worlds[0])
        .unwrap_err()
        .to_string();
    assert!(e.contains("config5_low.yaml") && e.contains("YAML"), "{e}");
    std::fs::write(
        root.join("Configs/Final/config5_low.yaml"),
        "terrain: {min_height: 0, max_height: 4.8, difficulty: extreme}\npositions: []\nterrain_type: rigid\nobstacle_density: sparse\ntextures: []\n",
    )
    .unwrap();
    let e = tasks::import::import_world(&worlds[0])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("terrain.difficulty") && e.contains("extreme"),
        "{e}"
    );
}

/// CRC-32 (PNG's, ISO 3309) of `bytes`.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xFFFF_FFFFu32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// Issue 58, point 8: a heightmap whose header claims 12000 x 12000 pixels is refused by its size, from the header,
/// before any pixel is decoded (this one's pixel data stops after four bytes, so a decoder would fail otherwise).
#[test]
fn an_oversized_heightmap_is_refused_from_its_header() {
    let dir = scratch("huge-png");
    copy_world(&dir, 3);
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend(12000u32.to_be_bytes());
    ihdr.extend(12000u32.to_be_bytes());
    ihdr.extend([16, 0, 0, 0, 0]); // 16-bit grayscale, deflate, no filter method, no interlace
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(13u32.to_be_bytes());
    png.extend(&ihdr);
    png.extend(crc32(&ihdr).to_be_bytes());
    // The start of the pixel data: a few bytes of a deflate stream that would go on for 288 MB.
    let idat = b"IDAT\x78\x9c\x00\x00".to_vec();
    png.extend(4u32.to_be_bytes());
    png.extend(&idat);
    png.extend(crc32(&idat).to_be_bytes());
    std::fs::write(dir.join("worlds/003.png"), png).unwrap();
    seal(&dir, &[3]);
    let e = match TaskSet::load(&dir) {
        Err(e) => e.to_string(),
        Ok(set) => set.world(3, 1.0).unwrap_err().to_string(),
    };
    assert!(e.contains("003.png") && e.contains("12000 x 12000"), "{e}");
}
