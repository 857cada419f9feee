use sim_core::characterize::{test_world, Ground};
use sim_core::planner::Action;
fn main() {
    let spec = sim_core::vehicle::vehicle_by_name(&std::env::args().nth(2).unwrap_or("hmmwv".into())).unwrap();
    let g = Ground::from_name(&std::env::args().nth(1).unwrap_or("mud".into())).unwrap();
    let w = test_world(g, 0.0, 1.0);
    let mut sim = sim_core::Simulation::new(&w, &spec, 0.0, 0.0, 0.0);
    println!("settle {}", sim.settle_time());
    for k in 0..7500 {
        sim.step(&Action { steering: 0.0, throttle: 0.0, brake: 1.0 });
        if k < 12 || k % 500 == 0 {
            let s = sim.state();
            let c: Vec<String> = sim.wheels().map(|w| format!("{:.5}/{:.0}/{:.0}/{:.4}", w.compression, w.force[0], w.normal_load, w.sinkage)).collect();
            println!("{k} x {:.5} z {:.5} vx {:.4} vz {:.4} wy {:.4} {:?}", s.position[0], s.position[2], s.velocity[0], s.velocity[2], s.angular_velocity[1], c);
        }
    }
}
