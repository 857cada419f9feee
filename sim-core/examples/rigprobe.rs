use sim_core::soil::rig::{Drive, WheelRig};
use sim_core::world::SoilParams;
fn main() {
    for (name, soil) in [("snow", SoilParams::SNOW), ("mud", SoilParams::MUD), ("sand", SoilParams::SAND)] {
        for passes in [1, 2] {
            let mut rig = WheelRig::new(soil, 0.467, 0.254, 2493.6 * 9.81 / 4.0);
            rig.passes = passes;
            let r: Vec<String> = [0.1, 0.3, 0.6, 0.9].iter().map(|&i| { let x = rig.run(Drive::Slip(i)); format!("{:.3}/{:.3}", x.drawbar_pull / rig.load, x.sinkage) }).collect();
            println!("{name} passes {passes}: {r:?}");
        }
    }
}
