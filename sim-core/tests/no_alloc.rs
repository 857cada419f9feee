//! The step loop allocates nothing: a counting global allocator sees no allocation during thousands of steps on
//! rough ground, soft soil and among obstacles, for a wheeled and a tracked vehicle.

// A counting global allocator needs `unsafe impl GlobalAlloc`; it only forwards to the system allocator.
#![allow(unsafe_code)]

mod common;
use common::*;
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Obstacle, ObstacleKind, Semantic, SoilParams, Surface};
use sim_core::Simulation;
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;
static ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Only allocations made by the thread under test count (the test harness's own threads may allocate at any
    /// time, for example to report a slow test).
    static COUNTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.with(|c| c.get()) {
            ALLOCS.fetch_add(1, Ordering::SeqCst);
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn stepping_allocates_nothing() {
    let mut w = world_with(
        |x, y| 0.5 * (0.2 * x).sin() * (0.15 * y).cos(),
        Surface::Rigid { friction: 0.7 },
    );
    for (i, p) in w.patches.iter_mut().enumerate() {
        if i % 3 == 0 {
            *p = sim_core::world::Patch {
                semantic: Semantic::Sand,
                surface: Surface::Deformable {
                    soil: SoilParams::SAND,
                },
            };
        }
    }
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: 10.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.4,
        half_extents: [2.0, 2.0, 1.5],
    });
    for name in ["hmmwv", "m113"] {
        let spec = vehicle_by_name(name).unwrap();
        let mut sim = Simulation::new(&w, &spec, -30.0, 0.0, 0.0);
        sim.step(&action(0.5, 0.2, 0.0));
        let before = ALLOCS.load(Ordering::SeqCst);
        COUNTING.with(|c| c.set(true));
        for k in 0..5000 {
            let steer = if k % 1000 < 500 { 0.3 } else { -0.3 };
            sim.step(&action(0.6, steer, 0.0));
        }
        COUNTING.with(|c| c.set(false));
        let after = ALLOCS.load(Ordering::SeqCst);
        assert_eq!(
            after - before,
            0,
            "{name}: {} allocations in 5000 steps",
            after - before
        );
        assert!(
            sim.soil().touched_tiles() > 0,
            "{name}: the soil was exercised"
        );
    }
}
