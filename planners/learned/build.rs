//! Compiles the committed weights of the built-in learned planners (`weights/<name>.safetensors`: the policies of
//! rl, mcl, acl, the kinodynamic models of mppi6 and tal and the traversability estimator of tnt) into the crate, so `vb`, the workers and the Python
//! wheel carry them; a name without a file is built without weights.

use std::path::Path;

const NAMES: [&str; 6] = ["rl", "mcl", "acl", "mppi6", "tal", "tnt"];

fn main() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("weights");
    println!("cargo:rerun-if-changed={}", dir.display());
    let mut out = String::from("/// The built-in learned planners and their compiled-in weights files, if this build has them.\n");
    out.push_str("pub(crate) const BUILTIN: [(&str, Option<&[u8]>); 6] = [\n");
    for name in NAMES {
        let file = dir.join(format!("{name}.safetensors"));
        println!("cargo:rerun-if-changed={}", file.display());
        if file.is_file() {
            out.push_str(&format!(
                "    (\"{name}\", Some(include_bytes!({:?}))),\n",
                file.display().to_string()
            ));
        } else {
            out.push_str(&format!("    (\"{name}\", None),\n"));
        }
    }
    out.push_str("];\n");
    let dest = Path::new(&std::env::var("OUT_DIR").expect("OUT_DIR")).join("builtin.rs");
    std::fs::write(dest, out).expect("writing builtin.rs");
}
