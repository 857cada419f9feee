//! Issue 58, point 7: `vb` finds the benchmark's task set it carries, wherever the binary lives: a copy of the
//! binary outside the checkout, run from elsewhere, unpacks the set into its versioned cache (every file checked)
//! and uses it by default; a damaged copy in the cache is replaced.

use integration::*;

fn committed_version() -> String {
    let m: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(tasks::TaskSet::default_dir().join("manifest.json"))
            .expect("manifest"),
    )
    .expect("json");
    m["version"].as_str().expect("version").to_string()
}

#[test]
fn a_copied_vb_uses_the_task_set_it_carries() {
    let dir = temp_dir("carried-set");
    let bin = dir.join("vb");
    std::fs::copy(vb(), &bin).expect("copy vb");
    let cache = dir.join("cache");
    let run = || {
        std::process::Command::new(&bin)
            .args(["tasks", "stats", "--json"])
            .current_dir(&dir)
            .env("VERTIBENCH_CACHE", &cache)
            .env_remove("VB_TASK_DIR")
            .output()
            .expect("vb")
    };
    let out = run();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let version = committed_version();
    let unpacked = cache.join("tasks").join(&version);
    assert!(
        unpacked.join("manifest.json").is_file(),
        "not unpacked into {}",
        unpacked.display()
    );
    let stats: serde_json::Value = serde_json::from_slice(&out.stdout).expect("stats json");
    assert!(stats.is_object(), "{stats}");
    // A damaged copy (one world file changed) is found by its hash and replaced on the next run.
    let world = unpacked.join("worlds").join("001.json");
    let mut text = std::fs::read_to_string(&world).expect("world");
    text.push(' ');
    std::fs::write(&world, text).expect("damage");
    let again = run();
    assert!(
        again.status.success(),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(again.stdout, out.stdout);
    let loaded = tasks::TaskSet::load(&unpacked).expect("the cache copy loads again");
    assert_eq!(loaded.version(), version);
}
