//! Prints the datasheet of a vehicle on every ground (`cargo run -p sim-core --example datasheet -- hmmwv [dt]`).
use sim_core::characterize::{datasheet, Ground, Setup};
fn main() {
    let args: Vec<String> = std::env::args().collect();
    let spec = sim_core::vehicle::vehicle_by_name(args.get(1).map_or("hmmwv", |s| s)).unwrap();
    let dt = args.get(2).and_then(|s| s.parse().ok());
    let only = args.get(3).and_then(|s| Ground::from_name(s));
    for ground in Ground::ALL {
        if only.is_some_and(|o| o != ground) {
            continue;
        }
        let d = datasheet(&spec, &Setup { ground, dt });
        println!("{}", serde_json::to_string(&d).unwrap());
    }
}
