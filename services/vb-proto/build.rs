//! Compiles `vertibench/v1/*.proto` with protox (a protobuf compiler written in Rust), so building needs no system
//! `protoc`.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let files = [
        "vertibench/v1/common.proto",
        "vertibench/v1/planner.proto",
        "vertibench/v1/sim.proto",
        "vertibench/v1/coordinator.proto",
    ];
    for f in &files {
        println!("cargo:rerun-if-changed={f}");
    }
    let fds = protox::compile(files, ["."])?;
    tonic_build::configure()
        .build_server(true)
        .build_client(true)
        .compile_fds(fds)?;
    Ok(())
}
