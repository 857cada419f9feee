//! Build-time inputs of the extension:
//! - the protocol's `.proto` files, compiled (with protox, no system `protoc`) into a serialized
//!   `FileDescriptorSet` that the extension ships: `vertibench.protocol` builds the Python message classes from it;
//!
//! The benchmark's task set comes compiled in through the tasks crate's `embedded` feature.

use prost::Message;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out_dir = PathBuf::from(std::env::var("OUT_DIR")?);
    let files = [
        "vertibench/v1/common.proto",
        "vertibench/v1/planner.proto",
        "vertibench/v1/sim.proto",
    ];
    for f in &files {
        println!("cargo:rerun-if-changed=../../proto/{f}");
    }
    let fds = protox::compile(files, ["../../proto"])?;
    std::fs::write(out_dir.join("vertibench.fds"), fds.encode_to_vec())?;
    Ok(())
}
