//! Random exploration's speed profiles: what the stop-and-go profile's stops do on a grade (braked: held; coasting:
//! rolling back at the grade's acceleration), and that the stop-and-go and fast profiles' draws come after the
//! paper's (`generate_rules.rs`: only random runs take them).

use anyhow::Result;
use datasets::generate::random::{draw, drive_sinusoid, Phase, RandomStart, Sinusoid, Stops};
use datasets::SpeedProfile;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use sim_core::episode::EpisodeConfig;
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Heightmap, Semantic, Surface, World};
use std::sync::Arc;

/// Grade of the test plane, deg: rising along +x.
const GRADE_DEG: f64 = 8.0;
const G: f64 = 9.81;

/// Frames (time, forward speed, throttle, brake) of `spec` driving the stop-and-go profile (go 8 s, stop 4 s) up the
/// test plane from rest, and the profile's stops.
type Frame = (f64, f64, f32, f32);

fn drive_stops(spec: &sim_core::VehicleSpec) -> (Vec<Frame>, Stops) {
    let tan = GRADE_DEG.to_radians().tan();
    let world = Arc::new(World::uniform(
        Heightmap::from_fn(1.0, |x, _| x * tan),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    ));
    let stops = Stops {
        go: 8.0,
        stop: 4.0,
        offset: 0.0,
    };
    let at = RandomStart {
        start: [-50.0, 0.0, 0.0],
        goal: [10.0, 0.0],
        sinusoid: Sinusoid {
            amplitude: 0.0,
            period: 6.0,
            phase: 0.0,
            speed: 2.0,
        },
        stops: Some(stops),
    };
    let rules = EpisodeConfig {
        max_time: 36.0,
        ..EpisodeConfig::default()
    };
    let rec = drive_sinusoid(&world, spec, &at, &rules, 20.0, None);
    // Frames by phase: (time, forward speed, throttle, brake).
    let frames: Vec<Frame> = rec
        .frames
        .state
        .iter()
        .zip(&rec.frames.action)
        .map(|(s, a)| (s[14], s[12], a[1], a[2]))
        .collect();
    assert!(
        frames.last().is_some_and(|f| f.0 > 35.0),
        "episode ended early: {:?}",
        rec.outcome
    );
    (frames, stops)
}

/// The forward speed at the first frame at or after `t`.
fn speed_at(frames: &[Frame], t: f64) -> f64 {
    frames
        .iter()
        .find(|f| f.0 >= t)
        .map(|f| f.1)
        .unwrap_or(f64::NAN)
}

#[test]
fn braked_stops_hold_the_vehicle_and_coasting_ones_roll_it_back_down_the_grade() -> Result<()> {
    // The textbook's free-rolling vehicle: the HMMWV without its engine's closed-throttle map (engine braking, which
    // `engine_braking_slows_a_coasting_stop_s_roll_back` checks).
    let mut free = vehicle_by_name("hmmwv")?;
    free.powertrain.zero_throttle_curve = None;
    let (frames, stops) = drive_stops(&free);
    let (mut braked, mut coasting) = (0, 0);
    for k in 0..3u32 {
        // Stop k spans [8 + 12 k, 12 + 12 k).
        let t0 = 8.0 + 12.0 * f64::from(k);
        let in_stop: Vec<_> = frames
            .iter()
            .filter(|f| f.0 >= t0 + 0.05 && f.0 < t0 + 3.95)
            .collect();
        let phase = stops.phase(t0 + 1.0);
        assert!(in_stop.iter().all(|f| f.2 == 0.0), "throttle in stop {k}");
        match phase {
            Phase::Brake => {
                braked += 1;
                assert!(in_stop.iter().all(|f| f.3 == 0.5));
                // Textbook: a braked wheel on dry ground (friction 0.8) holds an 8 deg grade (tan 0.14).
                let end = in_stop.iter().filter(|f| f.0 >= t0 + 2.0);
                for f in end {
                    assert!(
                        f.1.abs() < 0.05,
                        "braked stop {k}: {} m/s at {} s",
                        f.1,
                        f.0
                    );
                }
            }
            Phase::Coast => {
                coasting += 1;
                assert!(in_stop.iter().all(|f| f.3 == 0.0));
                // Textbook (Wong, Theory of Ground Vehicles, 3.1): a free-rolling vehicle accelerates down the grade
                // at g (sin(grade) - f cos(grade)); a tyre's rolling resistance f on hard ground is 0 to 0.03, so
                // over the stop's last 2 s it rolls back at 0.78 to 1.0 g sin(grade).
                let at_t = |t: f64| speed_at(&frames, t);
                let a = (at_t(t0 + 3.9) - at_t(t0 + 1.9)) / 2.0;
                let g_sin = G * GRADE_DEG.to_radians().sin();
                eprintln!("coasting stop {k}: {a:.3} m/s^2 against -{g_sin:.3}");
                assert!(at_t(t0 + 3.9) < -0.5, "coasting stop {k} did not roll back");
                assert!((-g_sin..=-0.78 * g_sin).contains(&a), "{a} m/s^2");
            }
            Phase::Go => panic!("stop {k} is not a stop"),
        }
    }
    assert_eq!((braked, coasting), (2, 1));
    Ok(())
}

/// The HMMWV as it is, with its engine's closed-throttle map (sim-core r10, `sim-core/tests/engine_map.rs`): the
/// coasting stop still rolls back down the grade, more slowly than the free-rolling vehicle, which the engine's
/// drag through the gearbox resists.
#[test]
fn engine_braking_slows_a_coasting_stop_s_roll_back() -> Result<()> {
    let mut free = vehicle_by_name("hmmwv")?;
    free.powertrain.zero_throttle_curve = None;
    let coast = |spec: &sim_core::VehicleSpec| {
        let (frames, stops) = drive_stops(spec);
        let t0 = (0..3u32)
            .map(|k| 8.0 + 12.0 * f64::from(k))
            .find(|t| stops.phase(t + 1.0) == Phase::Coast)
            .expect("a coasting stop");
        (
            speed_at(&frames, t0 + 3.9),
            (speed_at(&frames, t0 + 3.9) - speed_at(&frames, t0 + 1.9)) / 2.0,
        )
    };
    let (v_free, a_free) = coast(&free);
    let (v_engine, a_engine) = coast(&vehicle_by_name("hmmwv")?);
    eprintln!("roll-back: free {a_free:.3} m/s^2 ({v_free:.2} m/s), engine-braked {a_engine:.3} ({v_engine:.2})");
    assert!(
        v_engine < -0.5,
        "the coasting stop did not roll back: {v_engine} m/s"
    );
    assert!(
        a_free < a_engine && a_engine < 0.0,
        "{a_free} against {a_engine}"
    );
    Ok(())
}

#[test]
fn stops_are_drawn_after_the_papers_draws_so_those_stay_the_same() -> Result<()> {
    let world = World::uniform(
        Heightmap::from_fn(1.0, |_, _| 0.0),
        Semantic::Dirt,
        Surface::Rigid { friction: 0.8 },
    );
    let info = vehicle_by_name("hmmwv")?.info();
    for seed in 0..20 {
        let c = draw(
            &world,
            &info,
            SpeedProfile::Constant,
            &mut ChaCha8Rng::seed_from_u64(seed),
        );
        let s = draw(
            &world,
            &info,
            SpeedProfile::StopAndGo,
            &mut ChaCha8Rng::seed_from_u64(seed),
        );
        let (c, s) = (c.expect("free start"), s.expect("free start"));
        assert_eq!((c.start, c.goal, c.sinusoid), (s.start, s.goal, s.sinusoid));
        assert!(c.stops.is_none());
        let st = s.stops.expect("stops drawn");
        assert!((5.0..12.0).contains(&st.go) && (1.5..4.0).contains(&st.stop) && st.offset < st.go);
        assert_eq!(st.phase(0.0), Phase::Go);
        let p = s.params();
        assert_eq!((p["stop_go"], p["stop_duration"]), (st.go, st.stop));
    }
    Ok(())
}

#[test]
fn fast_speeds_are_drawn_after_the_papers_draws_and_span_the_range() -> Result<()> {
    let info = vehicle_by_name("hmmwv")?.info();
    for scale in [1.0, 1.0 / 6.0] {
        let mut world = World::uniform(
            Heightmap::from_fn(scale, |_, _| 0.0),
            Semantic::Dirt,
            Surface::Rigid { friction: 0.8 },
        );
        world.scale = scale;
        let mut speeds = Vec::new();
        for seed in 0..200 {
            let rng = |s| ChaCha8Rng::seed_from_u64(s);
            let c =
                draw(&world, &info, SpeedProfile::Constant, &mut rng(seed)).expect("free start");
            let f = draw(&world, &info, SpeedProfile::Fast, &mut rng(seed)).expect("free start");
            assert_eq!((c.start, c.goal, f.stops), (f.start, f.goal, None));
            let (cs, fs) = (c.sinusoid, f.sinusoid);
            assert_eq!(
                (cs.amplitude, cs.period, cs.phase),
                (fs.amplitude, fs.period, fs.phase)
            );
            // Froude similitude: speeds scale with sqrt(scale), as the paper's 2 m/s does.
            assert_eq!(cs.speed, 2.0 * scale.sqrt());
            let v = fs.speed / scale.sqrt();
            assert!((2.0..8.0).contains(&v), "{v} m/s at full scale");
            assert_eq!(f.params()["speed"], fs.speed);
            speeds.push(v);
        }
        // Uniform over [2, 8): every third of the range is drawn about a third of the time.
        for k in 0..3 {
            let lo = 2.0 + 2.0 * f64::from(k);
            let n = speeds
                .iter()
                .filter(|v| (lo..lo + 2.0).contains(*v))
                .count();
            assert!((45..=90).contains(&n), "{n} of 200 in [{lo}, {})", lo + 2.0);
        }
    }
    Ok(())
}
