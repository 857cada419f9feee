//! The online elevation map against scenes whose shadows are known analytically, its convergence to the truth with
//! the noise off, the fused variance with it on, and the layer's determinism across threads.

use contracts::TaskId;
use perception::map::{Mapper, Scan};
use perception::rng::{stream, Channel, EpisodeKey};
use perception::{Perception, Profile};
use sim_core::planner::{Action, VehicleState};
use sim_core::world::{Heightmap, Obstacle, ObstacleKind, Semantic, Surface, World};

fn key() -> EpisodeKey {
    EpisodeKey {
        task: TaskId::new(1, 0),
        seed: 0,
        profile: 1,
    }
}

fn world(f: impl Fn(f64, f64) -> f64) -> World {
    World::uniform(
        Heightmap::from_fn(1.0, f),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.6 },
    )
}

fn scan(origin: [f64; 3], noise_k: f64) -> Scan {
    Scan {
        origin,
        heading: 0.0,
        range: 30.0,
        fov: std::f64::consts::TAU,
        noise_k,
    }
}

/// Known state of the node at world (x, y) (1 m cells, the map centred on the origin).
fn known(m: &Mapper, x: i64, y: i64) -> bool {
    let (ix, iy) = ((x + 64) as usize, (y + 64) as usize);
    m.map.is_known(iy * m.map.nx + ix)
}

/// A wall 1 m high, 10 m ahead of a sensor 2 m up, on flat ground: by similar triangles the ground behind it is
/// hidden up to 20 m and seen beyond (the shadow does not depend on y for a wall across the view); everything in
/// front of it is seen. Nodes within two of the far boundary are left out: the wall's node is sampled anywhere in
/// its metre, which moves the shadow's end by up to one metre either way.
#[test]
fn a_wall_casts_its_analytic_shadow() {
    let mut w = world(|_, _| 0.0);
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: 10.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
        half_extents: [0.5, 20.0, 0.5],
    });
    let mut m = Mapper::new(&w, stream(&key(), Channel::Elevation));
    m.scan(&w, &scan([0.0, 0.0, 2.0], 0.0));
    for y in -5..=5 {
        for x in 1..=9 {
            assert!(known(&m, x, y), "({x}, {y}) in front of the wall is unseen");
        }
        for x in 11..=19 {
            assert!(!known(&m, x, y), "({x}, {y}) behind the wall is seen");
        }
        for x in 22..=28 {
            assert!(known(&m, x, y), "({x}, {y}) beyond the shadow is unseen");
        }
    }
    // Behind the sensor nothing occludes.
    assert!((1..=28).all(|r| known(&m, -r, 0)));
}

/// A ridge 3 m high at x = 10 (faces sloping 1 in 1) seen from 5 m up at the origin: the front face is seen, the
/// back face hidden, and the flat ground beyond hidden until the sight line over the crest (slope -0.2) meets it at
/// x = 25 (nodes within two of it left out, as for the wall).
#[test]
fn a_crest_hides_its_back_face_and_the_ground_behind() {
    let w = world(|x, _| (3.0 - (x - 10.0).abs()).max(0.0));
    let mut m = Mapper::new(&w, stream(&key(), Channel::Elevation));
    m.scan(&w, &scan([0.0, 0.0, 5.0], 0.0));
    for y in -5..=5 {
        for x in 1..=9 {
            assert!(known(&m, x, y), "({x}, {y}) on the front is unseen");
        }
        for x in 11..=23 {
            assert!(!known(&m, x, y), "({x}, {y}) behind the crest is seen");
        }
        for x in 27..=28 {
            assert!(known(&m, x, y), "({x}, {y}) beyond the shadow is unseen");
        }
    }
}

/// With the noise off the map is the truth wherever it is known, and driving across the map makes more of it known.
#[test]
fn with_noise_off_the_map_is_the_truth() {
    let w = world(|x, y| 2.0 * (x / 9.0).sin() * (y / 13.0).cos());
    let mut m = Mapper::new(&w, stream(&key(), Channel::Elevation));
    let mut last = 0;
    for k in 0..8 {
        let x = -40.0 + 10.0 * k as f64;
        let z = w.heightmap.height_bilinear(x, 0.0) + 2.0;
        m.scan(&w, &scan([x, 0.0, z], 0.0));
        let n = m.map.known_count();
        assert!(n > last, "scan {k} added nothing");
        last = n;
    }
    for (i, h) in w.heightmap.heights.iter().enumerate() {
        if m.map.is_known(i) {
            assert_eq!(m.map.height[i], *h);
            assert_eq!(m.map.variance[i], 0.0);
        } else {
            assert!(m.map.height[i].is_nan());
        }
    }
}

/// With noise `k d^2`, n views from one place leave each cell's variance at `k d^2 / n` (to f32 rounding), and the
/// errors normalised by it are standard normal (over the cells 5-25 m away: standard deviation within 5 %).
#[test]
fn repeated_views_fuse_by_inverse_variance() {
    let w = world(|_, _| 0.0);
    let mut m = Mapper::new(&w, stream(&key(), Channel::Elevation));
    let (k, n) = (0.0025, 4);
    for _ in 0..n {
        m.scan(&w, &scan([0.0, 0.0, 2.0], k));
    }
    let mut z = Vec::new();
    for iy in 0..m.map.ny {
        for ix in 0..m.map.nx {
            let (x, y) = w.heightmap.sample_position(ix, iy);
            let r = x.hypot(y);
            if !(5.0..=25.0).contains(&r) {
                continue;
            }
            let i = iy * m.map.nx + ix;
            let want = k * (r * r + 4.0) / n as f64;
            let var = f64::from(m.map.variance[i]);
            assert!(
                (var / want - 1.0).abs() < 1e-5,
                "({x}, {y}): {var} vs {want}"
            );
            z.push(f64::from(m.map.height[i]) / var.sqrt());
        }
    }
    let mean = z.iter().sum::<f64>() / z.len() as f64;
    let sd = (z.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / z.len() as f64).sqrt();
    assert!(
        (sd - 1.0).abs() < 0.05,
        "normalised error spread {sd} over {} cells",
        z.len()
    );
}

/// A 90-degree field of view sees nothing behind the sensor.
#[test]
fn the_field_of_view_limits_what_is_seen() {
    let w = world(|_, _| 0.0);
    let mut m = Mapper::new(&w, stream(&key(), Channel::Elevation));
    let mut s = scan([0.0, 0.0, 2.0], 0.0);
    s.fov = std::f64::consts::FRAC_PI_2;
    m.scan(&w, &s);
    assert!(known(&m, 10, 0) && known(&m, 10, 9));
    assert!(!known(&m, -10, 0) && !known(&m, 0, 10) && !known(&m, 10, 12));
}

/// One episode's layer under `degraded` driven along a line: the same inputs give the same perceptions on one
/// thread or four at once.
#[test]
fn the_layer_is_deterministic_across_threads() {
    let mut w = world(|x, y| (x / 7.0).sin() + (y / 5.0).cos());
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Tree,
        x: 15.0,
        y: 3.0,
        z: 0.0,
        yaw: 0.0,
        half_extents: [0.4, 0.4, 4.0],
    });
    let profile = Profile::builtin("degraded").unwrap();
    let run = |task: u32| {
        let mut p = Perception::new(&profile, &w, TaskId::new(1, task), [0.0, 0.0], 3, 0.6, 0.1);
        let mut out = Vec::new();
        for k in 0..100 {
            let truth = VehicleState {
                time: k as f64 * 0.1,
                position: [k as f64 * 0.3, 0.0, 1.0],
                velocity: [3.0, 0.0, 0.0],
                speed: 3.0,
                ..Default::default()
            };
            let seen = p.observe(&w, &truth);
            let known = seen.map.map_or(0, |m| m.known_count());
            out.push((seen.state, known, seen.obstacles.len()));
            let a = p.actuate(Action {
                steering: 0.1,
                throttle: 0.5,
                brake: 0.0,
            });
            out.push((
                VehicleState {
                    speed: a.throttle,
                    steering: a.steering,
                    ..Default::default()
                },
                0,
                0,
            ));
        }
        out
    };
    let serial: Vec<_> = (0..4).map(run).collect();
    let parallel: Vec<_> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..4).map(|t| s.spawn(move || run(t))).collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(serial, parallel);
    // Different tasks meet different noise; the same task the same.
    assert_ne!(serial[0], serial[1]);
    assert_eq!(serial[2], run(2));
}

/// The believed world holds what was seen, as the crops read it: behind a crest the elevation crop reads `NaN`
/// (unknown), in front it reads the truth (noise off); patches are the classified ones and obstacles the detected.
#[test]
fn the_belief_is_what_was_seen() {
    let mut w = world(|x, _| (3.0 - (x - 10.0).abs()).max(0.0));
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: -8.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
        half_extents: [0.5, 0.5, 0.5],
    });
    w.obstacles.push(Obstacle {
        kind: ObstacleKind::Rock,
        x: 50.0,
        y: 0.0,
        z: 0.0,
        yaw: 0.0,
        half_extents: [0.5, 0.5, 0.5],
    });
    let profile = Profile::from_toml(
        "seen",
        "[elevation]\nonline = true\nrange = 30.0\nfov_deg = 360.0\nmount_height = 4.0\nupdate_hz = 5.0\n\
         [obstacles]\ndetection_max = 1.0\n[semantics]\nerror_rate = 0.5\n",
    )
    .unwrap();
    let mut p = Perception::new(&profile, &w, TaskId::new(1, 0), [0.0, 0.0], 0, 0.6, 0.1);
    let truth = VehicleState {
        position: [0.0, 0.0, 1.0],
        ..Default::default()
    };
    let seen = p.observe(&w, &truth);
    let belief = seen.belief.world();
    assert_eq!(seen.belief.revision(), 1);
    // Front: known and true; behind the crest (x 11..23 with the sensor 5 m up): unknown.
    for x in [2.0, 5.0, 8.5] {
        assert!(seen.belief.is_known(x, 0.0));
        assert_eq!(
            belief.heightmap.height_bilinear(x, 0.0),
            w.heightmap.height_bilinear(x, 0.0)
        );
    }
    for x in [12.0, 16.5, 21.0] {
        assert!(!seen.belief.is_known(x, 0.0), "x = {x}");
    }
    let spec = sim_core::observe::CropSpec {
        size: 33,
        resolution: 1.0,
    };
    let mut crop = vec![0f32; 33 * 33];
    sim_core::observe::elevation_crop(belief, &truth, &spec, &mut crop);
    // Row 0 lies 16 m ahead (behind the crest), row 32 16 m behind (seen); column 16 is the centre line.
    let row = |r: usize, c: usize| crop[r * 33 + c];
    assert!(row(0, 16).is_nan() && !row(32, 16).is_nan());
    // The near rock is detected, the one 50 m away is not; patches are the classified ones.
    assert_eq!(belief.obstacles.len(), 1);
    assert_eq!(belief.obstacles[0].x, -8.0);
    assert_eq!(belief.patches, seen.patches);
    assert!(belief.patches.iter().any(|b| b.semantic != Semantic::Dirt));
}
