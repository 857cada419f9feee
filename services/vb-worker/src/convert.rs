//! Conversions between sim-core's types and the protocol's messages (protobuf stays at the service edge).

use sim_core::planner::{Action, Observation, VehicleInfo, VehicleState};
use sim_core::world::{Task, World};
use vb_proto::v1 as pb;

pub fn vehicle_state(s: &VehicleState) -> pb::VehicleState {
    pb::VehicleState {
        time: s.time,
        x: s.position[0],
        y: s.position[1],
        z: s.position[2],
        roll: s.roll,
        pitch: s.pitch,
        yaw: s.yaw,
        vx: s.velocity[0],
        vy: s.velocity[1],
        vz: s.velocity[2],
        wx: s.angular_velocity[0],
        wy: s.angular_velocity[1],
        wz: s.angular_velocity[2],
        speed: s.speed,
        steering: s.steering,
    }
}

pub fn vehicle_state_from_pb(s: &pb::VehicleState) -> VehicleState {
    VehicleState {
        time: s.time,
        position: [s.x, s.y, s.z],
        roll: s.roll,
        pitch: s.pitch,
        yaw: s.yaw,
        velocity: [s.vx, s.vy, s.vz],
        angular_velocity: [s.wx, s.wy, s.wz],
        speed: s.speed,
        steering: s.steering,
    }
}

pub fn action(a: &pb::Action) -> Action {
    Action {
        steering: a.steering,
        throttle: a.throttle,
        brake: a.brake,
    }
}

pub fn action_to_pb(a: &Action) -> pb::Action {
    pb::Action {
        steering: a.steering,
        throttle: a.throttle,
        brake: a.brake,
    }
}

pub fn vehicle_info(v: &VehicleInfo) -> pb::VehicleInfo {
    pb::VehicleInfo {
        name: v.name.clone(),
        scale: v.scale,
        wheelbase: v.wheelbase,
        track: v.track,
        length: v.length,
        width: v.width,
        max_steer: v.max_steer,
        skid_steer: v.skid_steer,
        nominal_speed: v.nominal_speed,
        max_speed: v.max_speed,
    }
}

fn vec2(p: [f64; 2]) -> pb::Vec2 {
    pb::Vec2 { x: p[0], y: p[1] }
}

pub fn task_info(task: &Task, world: &World, task_set_version: &str) -> pb::TaskInfo {
    pb::TaskInfo {
        task_id: task.id(),
        world_id: task.world_id,
        index: task.index,
        start: Some(vec2(task.start)),
        goal: Some(vec2(task.goal)),
        global_path: task.path.iter().map(|p| vec2(*p)).collect(),
        elevation_level: world.level.as_str().into(),
        semantics: world.semantics.as_str().into(),
        obstacle_density: world.density.as_str().into(),
        scale: world.scale,
        task_set_version: task_set_version.into(),
    }
}

/// The ground-truth maps of a world, sampled on its heightmap grid.
pub fn world_maps(world: &World) -> pb::WorldMaps {
    let h = &world.heightmap;
    let grid_f = |data: Vec<f32>| pb::GridF32 {
        nx: h.nx as u32,
        ny: h.ny as u32,
        cell: h.cell,
        data,
    };
    let grid_u = |data: Vec<u8>| pb::GridU8 {
        nx: h.nx as u32,
        ny: h.ny as u32,
        cell: h.cell,
        data,
    };
    pb::WorldMaps {
        elevation: Some(grid_f(h.heights.clone())),
        semantics: Some(grid_u(sim_core::observe::semantics_grid(world))),
        obstacles: Some(grid_u(sim_core::observe::occupancy_grid(world))),
        friction: Some(grid_f(sim_core::observe::friction_grid(world))),
    }
}

/// An observation with heading-aligned crops of `world` (the truth, or the belief) when `crop` is given; with a
/// belief the crops carry their known mask.
pub fn observation(
    obs: &Observation,
    world: &World,
    crop: Option<&sim_core::observe::CropSpec>,
) -> pb::Observation {
    let local = crop.map(|spec| {
        let n = spec.size * spec.size;
        let mut elev = vec![0f32; n];
        let mut sem = vec![0u8; n];
        let mut occ = vec![0u8; n];
        sim_core::observe::elevation_crop(world, &obs.state, spec, &mut elev);
        sim_core::observe::semantics_crop(world, &obs.state, spec, &mut sem);
        sim_core::observe::obstacle_crop(world, &obs.state, spec, &mut occ);
        let size = spec.size as u32;
        let known = obs.belief.is_some().then(|| pb::GridU8 {
            nx: size,
            ny: size,
            cell: spec.resolution,
            data: elev.iter().map(|z| u8::from(z.is_finite())).collect(),
        });
        pb::LocalMaps {
            elevation: Some(pb::GridF32 {
                nx: size,
                ny: size,
                cell: spec.resolution,
                data: elev,
            }),
            semantics: Some(pb::GridU8 {
                nx: size,
                ny: size,
                cell: spec.resolution,
                data: sem,
            }),
            obstacles: Some(pb::GridU8 {
                nx: size,
                ny: size,
                cell: spec.resolution,
                data: occ,
            }),
            known,
        }
    });
    pb::Observation {
        state: Some(vehicle_state(&obs.state)),
        local,
        map_update: None,
    }
}

/// A patch of the believed maps as the protocol's `MapUpdate` (on `world`'s grid: its cell size).
pub fn map_update(p: &perception::sync::MapPatch, world: &World) -> pb::MapUpdate {
    let cell = world.heightmap.cell;
    let grid_u = |data: Vec<u8>| pb::GridU8 {
        nx: p.nx as u32,
        ny: p.ny as u32,
        cell,
        data,
    };
    pb::MapUpdate {
        x0: p.x0 as u32,
        y0: p.y0 as u32,
        elevation: Some(pb::GridF32 {
            nx: p.nx as u32,
            ny: p.ny as u32,
            cell,
            data: p.heights.clone(),
        }),
        obstacles: Some(grid_u(p.obstacles.clone())),
        known: Some(grid_u(
            p.heights.iter().map(|z| u8::from(z.is_finite())).collect(),
        )),
    }
}
