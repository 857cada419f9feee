//! Build-time inputs of the extension:
//! - the protocol's `.proto` files, compiled (with protox, no system `protoc`) into a serialized
//!   `FileDescriptorSet` that the extension ships: `vertibench.protocol` builds the Python message classes from it;
//! - the benchmark's committed task set (`tasks/data/v4`), every file compiled in, so a wheel works on a machine
//!   that never saw the repository (`task_data.rs` writes it into a cache on first use).

use prost::Message;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The committed task set, relative to this crate.
const TASK_SET: &str = "../../tasks/data/v4";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = PathBuf::from(std::env::var("OUT_DIR")?);
    let files = [
        "vertibench/v1/common.proto",
        "vertibench/v1/planner.proto",
        "vertibench/v1/sim.proto",
    ];
    for f in &files {
        println!("cargo:rerun-if-changed=../../services/vb-proto/{f}");
    }
    let fds = protox::compile(files, ["../../services/vb-proto"])?;
    std::fs::write(out_dir.join("vertibench.fds"), fds.encode_to_vec())?;
    embed_task_set(Path::new(TASK_SET), &out_dir.join("task_set_files.rs"))
}

/// Writes `TASK_SET_FILES`, every file of the task set as `(relative path, bytes)` in path order.
fn embed_task_set(root: &Path, out: &Path) -> Result<(), Box<dyn std::error::Error>> {
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
