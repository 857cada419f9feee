//! `eval::external`'s protocol against sim-core on the other end of the pipe (issue 59 item 4's driver).

use eval::external::{drive, DriverIdentity, ExternalEnd};
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::planner::Planner;
use sim_core::vehicle::VehicleSpec;
use sim_core::world::{Heightmap, Semantic, Surface};
use sim_core::world::{Task, World};
use std::io::{BufRead, Write};
use std::io::{BufReader, Read};
use std::sync::Arc;

fn world() -> World {
    let h = Heightmap::from_fn(1.0, |x, y| 0.3 * (0.1 * x).sin() * (0.07 * y).cos());
    World::uniform(h, Semantic::Dirt, Surface::Rigid { friction: 0.6 })
}

fn task(goal: [f64; 2]) -> Task {
    Task {
        world_id: 1,
        index: 0,
        start: [-40.0, -10.0],
        goal,
        path: vec![[-40.0, -10.0], [0.0, 5.0], goal],
    }
}

fn pid() -> Box<dyn Planner> {
    registry::Builtin::resolve("pid", None).unwrap().make()
}

/// The other end of the pipe: sim-core's own vehicle, stepped with the driver's inputs, as the Chrono harness
/// steps Chrono's. Returns the driver's `ok` and `end` lines.
fn remote(
    world: &World,
    task: &Task,
    spec: &VehicleSpec,
    to: impl Write,
    from: impl Read,
) -> (String, String) {
    let (mut to, mut from) = (to, BufReader::new(from));
    let (x, y, yaw) = sim_core::runner::start_pose(task);
    let mut sim = sim_core::Simulation::new_shared(Arc::new(world.clone()), spec, x, y, yaw);
    let mut ask = |line: String| {
        writeln!(to, "{line}").unwrap();
        to.flush().unwrap();
        let mut a = String::new();
        from.read_line(&mut a).unwrap();
        a.trim_end().to_string()
    };
    let ok = ask(format!("dt {}", sim.dt()));
    let mut action = sim_core::Action::default();
    loop {
        let s = sim.state();
        let v = [
            s.time,
            s.position[0],
            s.position[1],
            s.position[2],
            s.roll,
            s.pitch,
            s.yaw,
            s.velocity[0],
            s.velocity[1],
            s.velocity[2],
            s.angular_velocity[0],
            s.angular_velocity[1],
            s.angular_velocity[2],
            s.speed,
            s.steering,
        ];
        let line = v
            .iter()
            .fold("state".to_string(), |l, x| format!("{l} {x}"));
        let a = ask(line);
        if let Some(end) = a.strip_prefix("end ") {
            return (ok, end.to_string());
        }
        if let Some(act) = a.strip_prefix("act ") {
            let n: Vec<f64> = act.split(' ').map(|w| w.parse().unwrap()).collect();
            action = sim_core::Action {
                steering: n[0],
                throttle: n[1],
                brake: n[2],
            };
        } else {
            assert_eq!(a, "same");
        }
        sim.step(&action);
    }
}

/// Drives `task` over the protocol with sim-core on the other end and in sim-core's own runner: the same
/// planner, rules and vehicle states must give the same end, bit for bit.
fn same_as_the_runner(task: &Task, cfg: &EpisodeConfig) -> ExternalEnd {
    let (world, spec) = (
        world(),
        sim_core::vehicle::vehicle_by_name("hmmwv").unwrap(),
    );
    // Two pipes: what the simulator writes the driver reads, and back.
    let (driver_reads, sim_writes) = std::io::pipe().unwrap();
    let (sim_reads, driver_writes) = std::io::pipe().unwrap();
    let (w, t, sp, c) = (world.clone(), task.clone(), spec.clone(), cfg.clone());
    let driver = std::thread::spawn(move || {
        drive(
            BufReader::new(driver_reads),
            driver_writes,
            &w,
            &t,
            &sp,
            pid().as_mut(),
            &c,
        )
        .unwrap()
    });
    let (ok, end) = remote(&world, task, &spec, sim_writes, sim_reads);
    let got = driver.join().unwrap();
    let identity: DriverIdentity = serde_json::from_str(ok.strip_prefix("ok ").unwrap()).unwrap();
    assert_eq!((identity.planner.as_str(), &identity.config), ("pid", cfg));
    assert_eq!(
        end,
        serde_json::to_string(&got).unwrap(),
        "the end line is the result"
    );
    let r = sim_core::run_episode(&world, task, &spec, pid().as_mut(), cfg);
    assert_eq!(
        (got.outcome, got.reason, got.detail.as_str()),
        (r.outcome, r.reason, r.detail.as_str())
    );
    assert_eq!(got.time.to_bits(), r.metrics.time.to_bits());
    assert_eq!(got.steps, r.metrics.steps);
    assert_eq!(got.path_length.to_bits(), r.metrics.path_length.to_bits());
    assert_eq!(
        got.final_goal_distance.to_bits(),
        r.metrics.final_goal_distance.to_bits()
    );
    got
}

#[test]
fn a_remote_sim_core_driven_over_the_pipe_ends_as_the_runner_does() {
    let reached = same_as_the_runner(&task([30.0, 20.0]), &EpisodeConfig::default());
    assert_eq!(reached.outcome, Outcome::Success);
    // Five seconds are not enough for 120 m: a timeout, under the release's rules too.
    let short = EpisodeConfig {
        max_time: 5.0,
        ..EpisodeConfig::release()
    };
    let out = same_as_the_runner(&task([60.0, 60.0]), &short);
    assert_eq!(out.outcome, Outcome::Timeout);
}

#[test]
fn malformed_lines_are_refused_with_their_line_number() {
    let (world, spec, t) = (
        world(),
        sim_core::vehicle::vehicle_by_name("hmmwv").unwrap(),
        task([30.0, 20.0]),
    );
    let cfg = EpisodeConfig::default();
    let run = |input: &str| {
        let mut out = Vec::new();
        let r = drive(
            input.as_bytes(),
            &mut out,
            &world,
            &t,
            &spec,
            pid().as_mut(),
            &cfg,
        );
        (
            r.map(|e| e.outcome).map_err(|e| e.to_string()),
            String::from_utf8(out).unwrap(),
        )
    };
    let zeros = "state 0 -40 -10 1 0 0 0.36 0 0 0 0 0 0 0 0\n";
    for (input, why) in [
        ("", "closed the pipe after 0 lines"),
        (
            "dt 0.5\n",
            "line 1 from the simulator: the step 0.5 s is not in (0, 0.02]",
        ),
        (
            "step 0.005\n",
            "line 1 from the simulator: expected `dt SECONDS`",
        ),
        (
            "dt 0.005\nstate 0 1 2\n",
            "line 2 from the simulator: 3 numbers after `state`, not 15",
        ),
        (
            "dt 0.005\nstate 0 -40 -10 1 0 0 x 0 0 0 0 0 0 0 0\n",
            "line 2 from the simulator: `x` is not a number",
        ),
    ] {
        let (r, _) = run(input);
        assert!(
            r.as_ref().is_err_and(|e| e.contains(why)),
            "{input:?}: {r:?}"
        );
    }
    let (r, out) = run(&format!("dt 0.005\n{zeros}"));
    assert!(r.is_err_and(|e| e.contains("closed the pipe after 2 lines")));
    assert!(
        out.starts_with("ok {") && out.lines().nth(1).is_some_and(|l| l.starts_with("act ")),
        "{out}"
    );
    let back = format!(
        "dt 0.005\n{}{zeros}",
        zeros.replacen("state 0", "state 1", 1)
    );
    assert!(run(&back)
        .0
        .is_err_and(|e| e.contains("line 3 from the simulator: time went back from 1 to 0")));
    // A vehicle reported upside down is judged as the runner judges it: overturned, a rollover.
    let flipped = format!(
        "dt 0.005\n{zeros}{}",
        zeros.replacen("0 0 0.36", "3.1 0 0.36", 1)
    );
    assert_eq!(run(&flipped).0, Ok(Outcome::Rollover));
}
