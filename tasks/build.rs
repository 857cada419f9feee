//! With the `embedded` feature: every file of the committed task set (`data/v4`) compiled in as
//! `TASK_SET_FILES`, so a binary finds the benchmark's set wherever it runs (`tasks::embedded`). Without it, an
//! empty list.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The committed task set, relative to this crate.
const TASK_SET: &str = "data/v4";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-env-changed=CARGO_FEATURE_EMBEDDED");
    let out = PathBuf::from(std::env::var("OUT_DIR")?).join("task_set_files.rs");
    if std::env::var_os("CARGO_FEATURE_EMBEDDED").is_none() {
        std::fs::write(out, "pub static TASK_SET_FILES: &[(&str, &[u8])] = &[];\n")?;
        return Ok(());
    }
    embed(Path::new(TASK_SET), &out)
}

/// Writes `TASK_SET_FILES`, every file of the set as `(relative path, bytes)` in path order.
fn embed(root: &Path, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
    println!("cargo:rerun-if-changed={}", root.display());
    let mut files = Vec::new();
    collect(root, root, &mut files)?;
    files.sort();
    if !files.iter().any(|f| f == "manifest.json") {
        return Err(format!("{}: no manifest.json", root.display()).into());
    }
    let mut src =
        String::from("/// The benchmark's task set: `(path relative to the set, bytes)`.\n");
    src.push_str("pub static TASK_SET_FILES: &[(&str, &[u8])] = &[\n");
    for rel in &files {
        let abs = std::fs::canonicalize(root.join(rel))?;
        println!("cargo:rerun-if-changed={}", abs.display());
        writeln!(
            src,
            "    ({rel:?}, include_bytes!({:?})),",
            abs.display().to_string()
        )?;
    }
    src.push_str("];\n");
    std::fs::write(out, src)?;
    Ok(())
}

fn collect(
    root: &Path,
    dir: &Path,
    files: &mut Vec<String>,
) -> Result<(), Box<dyn std::error::Error>> {
    for entry in std::fs::read_dir(dir)? {
        let path = entry?.path();
        if path.is_dir() {
            println!("cargo:rerun-if-changed={}", path.display());
            collect(root, &path, files)?;
        } else {
            let rel = path.strip_prefix(root)?;
            let rel = rel
                .to_str()
                .ok_or_else(|| format!("{}: not UTF-8", path.display()))?
                .replace('\\', "/");
            files.push(rel);
        }
    }
    Ok(())
}
