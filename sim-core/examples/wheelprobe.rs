use sim_core::characterize::{test_world, Ground};
use sim_core::planner::Action;
fn main() {
    let spec = sim_core::vehicle::vehicle_by_name("hmmwv").unwrap();
    let deg: f64 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(3.0);
    let w = test_world(Ground::Snow, deg, 1.0);
    let mut sim = sim_core::Simulation::new(&w, &spec, -100.0, 0.0, 0.0);
    for k in 0..5000 {
        sim.step(&Action { steering: 0.0, throttle: 1.0, brake: 0.0 });
        if k % 500 == 499 {
            let s = sim.state();
            let r: Vec<String> = sim.wheels().map(|w| format!("fx {:.0} n {:.0} slip {:.2} sink {:.3}", w.force[0], w.normal_load, w.slip, w.sinkage)).collect();
            println!("t {:.1} v {:.2} gear {} {:?}", s.time, s.speed, sim.gear(), r);
        }
    }
}
