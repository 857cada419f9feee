//! The move-off check (`sim_core::move_off`): a vehicle moves off from a start on open soft ground and does not from
//! the bottom of a bowl whose walls steepen past the grade it can climb (the datasheet's grade, `soil_vehicle.rs`:
//! the HMMWV climbs about 19 degrees of snow).

use sim_core::characterize::{test_world, Ground};
use sim_core::move_off::{move_off_distance, moves_off, MOVE_OFF_DISTANCE};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Heightmap, Semantic, SoilParams, Surface, Task, World};

fn task() -> Task {
    Task {
        world_id: 0,
        index: 0,
        start: [0.0, 0.0],
        goal: [40.0, 0.0],
        path: vec![[0.0, 0.0], [40.0, 0.0]],
    }
}

#[test]
fn a_vehicle_moves_off_on_open_soil_and_not_from_a_bowl_it_cannot_climb_out_of() {
    let spec = vehicle_by_name("hmmwv").unwrap();
    let flat = test_world(Ground::Snow, 0.0, 1.0);
    let moved = move_off_distance(&flat, &task(), &spec, None);
    assert!(
        moved > 10.0 * MOVE_OFF_DISTANCE,
        "on flat snow it moved {moved} m"
    );
    // A paraboloid of snow whose wall is 35 degrees steep 5 m from its centre: the HMMWV gets up to where it is
    // 19 degrees steep, 2.5 m out.
    let k = 35f64.to_radians().tan() / (2.0 * 5.0);
    let bowl = World::uniform(
        Heightmap::from_fn(0.5, |x, y| k * (x * x + y * y)),
        Semantic::Snow,
        Surface::Deformable {
            soil: SoilParams::SNOW,
        },
    );
    let moved = move_off_distance(&bowl, &task(), &spec, None);
    assert!(
        moved < MOVE_OFF_DISTANCE,
        "out of the bowl it moved {moved} m"
    );
    assert!(!moves_off(&bowl, &task(), &spec, None));
}
