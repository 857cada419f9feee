//! Soil Contact Model checks through the public API: flat-plate Bekker sinkage, elastic unloading, Janosi shear,
//! several soils in one world, determinism (the rigid wheel against Bekker and Wong-Reece: `soil_wheel_theory.rs`).

use nalgebra::Vector3;
use sim_core::soil::{PlateGeometry, SoilContact, SoilGrid, WheelGeometry};
use sim_core::world::*;

fn soil_world(soil: SoilParams) -> World {
    World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Mud,
        Surface::Deformable { soil },
    )
}

/// A 0.6 m x 0.6 m horizontal plate centred half-way between nodes, so it covers exactly 6 x 6 nodes of 0.1 m:
/// the discrete contact area equals the plate's area (0.36 m^2).
const SIDE: f64 = 0.6;
const AREA: f64 = SIDE * SIDE;

fn plate(z: f64, vx: f64) -> PlateGeometry {
    PlateGeometry {
        centre: Vector3::new(0.05, 0.05, z),
        forward: Vector3::x(),
        up: Vector3::z(),
        length: SIDE,
        width: SIDE,
        velocity: Vector3::new(vx, 0.0, 0.0),
        angular_velocity: Vector3::zeros(),
    }
}

fn press(grid: &mut SoilGrid, z: f64) -> SoilContact {
    grid.begin_step();
    grid.plate_contact(&plate(z, 0.0), 1e-3)
}

/// Lowers the plate in 10 um steps until the soil carries `load`; returns the plate's depth below the surface.
fn plate_sinkage(grid: &mut SoilGrid, load: f64) -> f64 {
    let mut z = 0.0;
    while z > -0.5 {
        if press(grid, z).normal >= load {
            return -z;
        }
        z -= 1e-5;
    }
    panic!("the soil never carried {load} N");
}

fn bekker(soil: SoilParams, b: f64, p: f64) -> f64 {
    (p / (soil.k_c / b + soil.k_phi)).powf(1.0 / soil.n)
}

#[test]
fn flat_plate_static_sinkage_matches_bekker() {
    // Tolerance 3% (the issue asks for 10%): the plate is lowered in 10 um steps and its area is resolved exactly,
    // so the only error is the step quantisation (0.05 mm against sinkages of 2 mm to 12 cm).
    for (soil, pressure) in [
        (SoilParams::SAND, 40e3),
        (SoilParams::MUD, 20e3),
        (SoilParams::SNOW, 20e3),
    ] {
        let mut grid = SoilGrid::new(soil_world(soil));
        let sim = plate_sinkage(&mut grid, pressure * AREA);
        let z = bekker(soil, SIDE, pressure);
        assert!(
            (sim - z).abs() <= 0.03 * z,
            "{soil:?}: sinkage {sim:.5} m vs Bekker {z:.5} m"
        );
    }
}

#[test]
fn unloading_and_reloading_follow_the_elastic_line_until_the_previous_yield() {
    let soil = SoilParams::MUD;
    let mut grid = SoilGrid::new(soil_world(soil));
    let z1 = 0.03;
    let yield_load = press(&mut grid, -z1).normal;
    let yield_p = (soil.k_c / SIDE + soil.k_phi) * z1.powf(soil.n);
    assert!((yield_load / AREA - yield_p).abs() < 1e-6 * yield_p);
    let plastic = z1 - yield_p / soil.elastic_k;
    // The rut is the plastic sinkage (relative 1e-9: plain arithmetic).
    assert!((grid.surface_height(0.05, 0.05) + plastic).abs() < 1e-9 * plastic);
    // Unload part-way, reload: pressure is K_e times the penetration of the rut, both ways (relative 1e-9).
    for depth in [z1 - 2e-5, plastic + 1e-5, z1 - 1e-5, z1] {
        let p = press(&mut grid, -depth).normal / AREA;
        let elastic = soil.elastic_k * (depth - plastic);
        assert!(
            (p - elastic).abs() <= 1e-9 * yield_p,
            "depth {depth}: {p} Pa vs elastic line {elastic} Pa"
        );
    }
    // Above the rut floor there is no contact at all.
    assert_eq!(press(&mut grid, -0.5 * plastic).nodes, 0);
    // Past the previous yield the Bekker curve takes over again (relative 1e-6).
    let z2 = 0.04;
    let p2 = press(&mut grid, -z2).normal / AREA;
    let bekker2 = soil.k_phi * z2.powf(soil.n);
    assert!((p2 - bekker2).abs() < 1e-6 * bekker2, "{p2} vs {bekker2}");
}

#[test]
fn janosi_shear_builds_up_with_slip_distance_and_saturates_at_mohr_coulomb() {
    for soil in [SoilParams::SAND, SoilParams::MUD] {
        let mut grid = SoilGrid::new(soil_world(soil));
        let z = 0.02;
        let sigma = press(&mut grid, -z).normal / AREA;
        let tau_max = soil.cohesion + sigma * soil.friction_angle_deg.to_radians().tan();
        // Slide at 0.1 m/s for 0.04 m (no node enters or leaves the plate); dt 1 ms, so j grows by 0.1 mm a step.
        let (v, dt) = (0.1, 1e-3);
        let mut last = 0.0;
        for k in 1..=400 {
            grid.begin_step();
            let mut pl = plate(-z, v);
            pl.centre.x += v * dt * k as f64;
            let c = grid.plate_contact(&pl, dt);
            // The step's shear acts at the displacement reached half-way through the step (the midpoint rule).
            let j = v * dt * (k as f64 - 0.5);
            let expected = tau_max * (1.0 - (-j / soil.janosi_k).exp()) * AREA;
            // Shear opposes the slip (relative 1e-6: the sliding plate re-presses the same nodes elastically).
            assert!(
                (-c.force.x - expected).abs() <= 1e-6 * tau_max * AREA,
                "{soil:?} j {j}: {} vs {expected}",
                -c.force.x
            );
            assert!(-c.force.x >= last, "shear never decreases while slipping");
            last = -c.force.x;
        }
        // After j = 0.04 m >= 3.3 K the shear is within 4% of the Mohr-Coulomb limit.
        assert!(last > 0.96 * tau_max * AREA && last <= tau_max * AREA);
    }
}

#[test]
fn each_cell_takes_the_soil_of_its_patch() {
    let mut world = soil_world(SoilParams::MUD);
    // Patch (0, 0) is snow, its neighbour along +x is rigid rock.
    world.patches[0] = Patch {
        semantic: Semantic::Snow,
        surface: Surface::Deformable {
            soil: SoilParams::SNOW,
        },
    };
    world.patches[1] = Patch {
        semantic: Semantic::Rock,
        surface: Surface::Rigid { friction: 0.8 },
    };
    let stride = PATCH_STRIDE as f64 * world.heightmap.cell;
    let (snow_x, rock_x, y) = (
        -64.0 + 0.5 * stride,
        -64.0 + 1.5 * stride,
        -64.0 + 0.5 * stride,
    );
    let mut grid = SoilGrid::new(world);
    assert_eq!(grid.soil_at(snow_x, y), Some(SoilParams::SNOW));
    assert_eq!(grid.soil_at(0.0, 0.0), Some(SoilParams::MUD));
    assert!(!grid.has_soil_at(rock_x, y));
    let mut sink_at = |x: f64| {
        let mut p = plate(0.0, 0.0);
        p.centre = Vector3::new(x + 0.05, y + 0.05, -0.02);
        grid.begin_step();
        grid.plate_contact(&p, 1e-3).normal
    };
    let (snow, mud, rock) = (
        sink_at(snow_x),
        sink_at(0.0 - 64.0 + 4.5 * stride),
        sink_at(rock_x),
    );
    assert_eq!(rock, 0.0, "no soil force on rigid ground");
    let ratio = mud / snow;
    // Same depth: the pressures stand as the soils' k_phi (mud 2e6, snow 2e5), relative 1e-9.
    assert!((ratio - 10.0).abs() < 1e-8, "{ratio}");
}

#[test]
fn identical_inputs_give_bit_identical_forces_and_reset_restores_fresh_soil() {
    let run = |grid: &mut SoilGrid| {
        (0..500)
            .map(|k| {
                grid.begin_step();
                let w = WheelGeometry {
                    centre: Vector3::new(0.002 * k as f64, 0.0, 0.46),
                    axle: Vector3::new(0.1, 1.0, 0.0).normalize(),
                    radius: 0.5,
                    width: 0.3,
                    velocity: Vector3::new(2.0, 0.0, -0.01),
                    angular_velocity: Vector3::new(0.0, 5.0, 0.0),
                };
                let c = grid.wheel_contact(&w, 1e-3);
                [
                    c.force.x.to_bits(),
                    c.force.y.to_bits(),
                    c.force.z.to_bits(),
                ]
            })
            .collect::<Vec<_>>()
    };
    let mut grid = SoilGrid::new(soil_world(SoilParams::SAND));
    let first = run(&mut grid);
    assert!(grid.touched_cells() > 0);
    grid.reset();
    assert_eq!(grid.touched_cells(), 0);
    assert_eq!(grid.surface_height(0.5, 0.0), 0.0);
    assert_eq!(
        first,
        run(&mut grid),
        "after reset the same inputs give the same bits"
    );
    let mut other = SoilGrid::new(soil_world(SoilParams::SAND));
    assert_eq!(first, run(&mut other));
}

/// A plate pressed into mud and pushed sideways by a steady force of half its Mohr-Coulomb shear capacity is held:
/// Janosi-Hanamoto (`tau / tau_max = 1 - exp(-j / K)`) puts its static rest at `j = K ln 2`; the shear is kept while
/// the plate is at rest or swings back, so it holds like an elastic-plastic bristle instead of creeping (what a
/// parked vehicle on a slope needs). Horizontal motion of 500 kg integrated linearly implicitly with
/// `traction_stiffness` at the vehicle's 4 ms step for 30 s. Nothing damps the tangential motion but the plastic
/// work of the first swing, so the plate keeps swinging elastically about its rest: checked are the swing's range
/// (between `K ln 2` and the first overshoot, which undamped is below `3 K ln 2`) and that it does not drift (the
/// range over 20-30 s equals that over 10-20 s within 0.1 mm).
#[test]
fn a_plate_under_a_steady_sideways_load_below_its_shear_capacity_is_held_without_creep() {
    let soil = SoilParams::MUD;
    let mut grid = SoilGrid::new(soil_world(soil));
    let z = -0.02;
    let sigma = press(&mut grid, z).normal / AREA;
    let tau_max = soil.cohesion + sigma * soil.friction_angle_deg.to_radians().tan();
    let (force, mass, dt) = (0.5 * tau_max * AREA, 500.0, 4e-3);
    let (mut x, mut v) = (0.0, 0.0);
    let mut ranges = [(f64::INFINITY, f64::NEG_INFINITY); 3];
    for k in 0..7500 {
        grid.begin_step();
        let mut p = plate(z, v);
        p.centre.x += x;
        let c = grid.plate_contact(&p, dt);
        v += dt * (force + c.force.x) / (mass + dt * c.traction_stiffness);
        x += dt * v;
        let r = &mut ranges[k / 2500];
        *r = (r.0.min(x), r.1.max(x));
    }
    let rest = soil.janosi_k * 2f64.ln();
    let (lo, hi) = ranges[2];
    assert!(
        lo >= 0.5 * rest && hi <= 3.0 * rest,
        "swings over [{lo:.5}, {hi:.5}] m; static rest K ln 2 = {rest:.5} m"
    );
    for e in [ranges[2].0 - ranges[1].0, ranges[2].1 - ranges[1].1] {
        assert!(e.abs() < 1e-4, "drifts: {ranges:?}");
    }
}
