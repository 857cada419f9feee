//! Hand-made worlds for the physics tests.
#![allow(dead_code)]

use sim_core::world::*;

/// A 129 x 129 world at 1 m whose height is `f(x, y)`, one surface everywhere, no obstacles.
pub fn world_with(f: impl Fn(f64, f64) -> f64, surface: Surface) -> World {
    let n = 129;
    let mut heights = vec![0f32; n * n];
    for iy in 0..n {
        for ix in 0..n {
            heights[iy * n + ix] = f(ix as f64 - 64.0, iy as f64 - 64.0) as f32;
        }
    }
    let semantic = match surface {
        Surface::Rigid { .. } => Semantic::Concrete,
        Surface::Deformable { .. } => Semantic::Mud,
    };
    World {
        id: 1,
        scale: 1.0,
        level: ElevationLevel::Low,
        semantics: SemanticsKind::Rigid,
        density: ObstacleDensity::Sparse,
        heightmap: Heightmap {
            nx: n,
            ny: n,
            cell: 1.0,
            heights,
        },
        patches: vec![Patch { semantic, surface }; PATCHES * PATCHES],
        obstacles: Vec::new(),
    }
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
