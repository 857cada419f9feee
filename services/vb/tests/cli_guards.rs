//! `vb` refuses what would destroy data by accident.

#[test]
fn tasks_generate_needs_an_output_directory() {
    // Without --out it used to overwrite the benchmark's committed task set.
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
        .args(["tasks", "generate"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--out"), "{err}");
}

#[test]
fn admin_token_create_without_a_store_here_explains_instead_of_making_one() {
    let dir = std::env::temp_dir().join(format!("vb-admin-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_vb"))
        .args(["admin", "token", "create", "--name", "alice"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no store at out/vb.db") && err.contains("--db"),
        "{err}"
    );
    assert!(!dir.join("out").exists(), "no empty store was made");
}
