//! Hand-made worlds for the physics tests.
#![allow(dead_code)]

use sim_core::world::*;

/// A 129 x 129 world at 1 m whose height is `f(x, y)`, one surface everywhere, no obstacles.
pub fn world_with(f: impl Fn(f64, f64) -> f64, surface: Surface) -> World {
    let semantic = match surface {
        Surface::Rigid { .. } => Semantic::Concrete,
        Surface::Deformable { .. } => Semantic::Mud,
    };
    World::uniform(Heightmap::from_fn(1.0, f), semantic, surface)
}

pub fn flat(mu: f64) -> World {
    world_with(|_, _| 0.0, Surface::Rigid { friction: mu })
}

/// A plane rising along +x at angle `deg`.
pub fn slope_x(deg: f64, mu: f64) -> World {
    let t = deg.to_radians().tan();
    world_with(
        move |x, _| x * t + 64.0 * t,
        Surface::Rigid { friction: mu },
    )
}

/// A plane rising along +y (a side slope for a vehicle heading along x).
pub fn slope_y(deg: f64, mu: f64) -> World {
    let t = deg.to_radians().tan();
    world_with(
        move |_, y| y * t + 64.0 * t,
        Surface::Rigid { friction: mu },
    )
}

pub fn action(throttle: f64, steering: f64, brake: f64) -> sim_core::planner::Action {
    sim_core::planner::Action {
        steering,
        throttle,
        brake,
    }
}

/// Steps `sim` for `seconds` with the action `a`.
pub fn run(sim: &mut sim_core::Simulation, seconds: f64, a: sim_core::planner::Action) {
    for _ in 0..(seconds / sim.dt()).round() as usize {
        sim.step(&a);
    }
}
