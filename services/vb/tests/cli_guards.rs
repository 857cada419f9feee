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
