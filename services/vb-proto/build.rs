//! Compiles the protocol, `proto/vertibench/v1/*.proto` at the workspace's top (every build reads it there), with
//! protox (a protobuf compiler written in Rust), so building needs no system `protoc`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let files = [
        "vertibench/v1/common.proto",
        "vertibench/v1/planner.proto",
        "vertibench/v1/sim.proto",
        "vertibench/v1/coordinator.proto",
    ];
    for f in &files {
        println!("cargo:rerun-if-changed=../../proto/{f}");
    }
    let fds = protox::compile(files, ["../../proto"])?;
    tonic_build::configure()
        .build_server(true)
        .build_client(true)
        .compile_fds(fds)?;
    Ok(())
}
