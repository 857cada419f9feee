//! Compiles the protocol's `.proto` files (with protox, no system `protoc`) into a serialized
//! `FileDescriptorSet` that the extension ships: `vertibench.protocol` builds the Python message classes from it.

use prost::Message;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let files = [
        "vertibench/v1/common.proto",
        "vertibench/v1/planner.proto",
        "vertibench/v1/sim.proto",
    ];
    for f in &files {
        println!("cargo:rerun-if-changed=../../services/vb-proto/{f}");
    }
    let fds = protox::compile(files, ["../../services/vb-proto"])?;
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR")?).join("vertibench.fds");
    std::fs::write(out, fds.encode_to_vec())?;
    Ok(())
}
