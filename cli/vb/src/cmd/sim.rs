//! `vb sim`: one episode with its trajectory and plot (`run`), the datasheet's scenarios and the Chrono harness'
//! counterparts (`characterize`, `climb`, `roll-back`, `drive`, `episodes`), the vehicle catalogue.

use clap::Subcommand;
use sim_core::episode::EpisodeConfig;
use std::path::PathBuf;

/// `vb sim run`'s arguments.
#[derive(clap::Args)]
pub struct RunArgs {
    #[arg(long)]
    world: u32,
    /// Task index within the world (0..9).
    #[arg(long, default_value_t = 0)]
    task: u32,
    #[arg(long, default_value = "hmmwv")]
    vehicle: String,
    /// pure_pursuit (built-in controller) or any built-in planner of `vb eval`.
    #[arg(long, default_value = "pure_pursuit")]
    planner: String,
    #[arg(long)]
    scale: Option<f64>,
    #[arg(long)]
    task_dir: Option<PathBuf>,
    /// Trajectory recording rate, Hz.
    #[arg(long, default_value_t = 20.0)]
    record_hz: f64,
    #[arg(long, default_value = "out/sim")]
    out: PathBuf,
}

#[derive(Subcommand)]
pub enum SimCmd {
    /// Run one episode and write trajectory.csv, episode.png and result.json.
    Run(RunArgs),
    /// The steepest-grade scenario at the given grades (climbs or not, by the datasheet's criterion), with a
    /// per-wheel trace in the Chrono reference harness's CSV columns (`chrono-reference climb --trace`); columns
    /// sim-core does not model (engine speed, the chassis' and suspension's soil forces) are left empty, and the
    /// soil's moment off soil.
    Climb {
        #[arg(long, default_value = "hmmwv")]
        vehicle: String,
        /// rigid (concrete, mu 0.85), snow, mud or sand.
        #[arg(long)]
        surface: String,
        /// Grades, degrees, comma-separated (0 to 60).
        #[arg(long, value_delimiter = ',', required = true)]
        grade: Vec<f64>,
        /// Physics step, s (default: the vehicle's).
        #[arg(long)]
        dt: Option<f64>,
        /// Write the trace here (CSV, one row per wheel per sample).
        #[arg(long)]
        trace: Option<PathBuf>,
        /// Sample interval of the trace, s.
        #[arg(long, default_value_t = 0.05)]
        every: f64,
    },
    /// List the vehicle catalogue.
    Vehicles,
    /// Drive one task of a task set in a simulator on the other end of stdin and stdout (the Chrono harness's
    /// `episodes --driver`): a built-in planner acts and the benchmark's rules judge, over the lock-step line
    /// protocol of `eval::external`; the end is the last line written.
    Drive {
        /// The task set (default: the benchmark's).
        #[arg(long)]
        task_dir: Option<PathBuf>,
        /// The task, e.g. w001-t3.
        #[arg(long)]
        task: contracts::TaskId,
        #[arg(long, default_value = "pid")]
        planner: String,
        #[arg(long, default_value = "hmmwv")]
        vehicle: String,
        /// The original release's rules (8 m goal radius, speed-based stuck, its rollover classification).
        #[arg(long)]
        release_rules: bool,
    },
    /// Whole episodes beside a reference simulator's (the Chrono harness's `episodes --out`): sim-core drives the
    /// same tasks with the same planner and rules and prints both outcome by outcome, and how often they agree.
    Episodes {
        /// The task set the reference ran on (default: the benchmark's).
        #[arg(long)]
        task_dir: Option<PathBuf>,
        #[arg(long)]
        reference: PathBuf,
        #[arg(long, default_value = "hmmwv")]
        vehicle: String,
        #[arg(long)]
        json: bool,
    },
    /// A coasting stop's roll-back, as the Chrono harness's `roll-back`: settled facing up a plane of the grade with
    /// the brakes on, then throttle and brakes released; CSV in the harness's columns (t, speed, engine_speed,
    /// engine_torque, gear), the engine's left empty.
    RollBack {
        #[arg(long, default_value = "hmmwv")]
        vehicle: String,
        /// rigid (concrete, mu 0.85), snow, mud or sand.
        #[arg(long, default_value = "rigid")]
        surface: String,
        /// Grade, degrees (0 to 60).
        #[arg(long)]
        grade: f64,
        /// Seconds after the release (0 to 60).
        #[arg(long, default_value_t = 4.0)]
        seconds: f64,
        /// Physics step, s (default: the vehicle's).
        #[arg(long)]
        dt: Option<f64>,
    },
    /// A vehicle's datasheet: static sinkage and ride height, full-throttle speeds and distance, braking, the
    /// steepest climbable grade, tilt-table slide and tip angles, turning radii (sim_core::characterize).
    Characterize {
        #[arg(long, default_value = "hmmwv")]
        vehicle: String,
        /// rigid (concrete, mu 0.85), snow, mud, sand or all.
        #[arg(long, default_value = "all")]
        surface: String,
        /// Physics step, s (default: the vehicle's).
        #[arg(long)]
        dt: Option<f64>,
        /// Print JSON (`{"datasheets": [..], "move_off": {..} or null}`) instead of a table.
        #[arg(long)]
        json: bool,
        /// Also run the move-off check from every start of this task set (e.g. the release's original worlds,
        /// `vb tasks import-verti-bench`): full throttle towards the goal for 20 s; prints how many starts the
        /// vehicle cannot get 5 m away from (sim_core::move_off).
        #[arg(long)]
        task_dir: Option<PathBuf>,
        /// A reference's datasheets (JSON in --json's schema, e.g. the Chrono harness's): prints every figure of
        /// both with the ratio and whether ours is within tolerance (angles 4 deg, everything else 20%). With
        /// --task-dir and a reference holding the move-off check (the harness's `move-off`): both start by start
        /// and how often they agree.
        #[arg(long)]
        reference: Option<PathBuf>,
    },
}

pub fn run(cmd: SimCmd) -> anyhow::Result<()> {
    match cmd {
        SimCmd::Run(a) => run_one(a)?,
        SimCmd::Characterize {
            vehicle,
            surface,
            dt,
            json,
            task_dir,
            reference,
        } => super::sim_characterize::run(super::sim_characterize::Args {
            vehicle,
            surface,
            dt,
            json,
            task_dir,
            reference,
        })?,
        SimCmd::Climb {
            vehicle,
            surface,
            grade,
            dt,
            trace,
            every,
        } => climb(&vehicle, &surface, &grade, dt, trace.as_deref(), every)?,
        SimCmd::RollBack {
            vehicle,
            surface,
            grade,
            seconds,
            dt,
        } => {
            let spec = sim_core::vehicle::vehicle_by_name(&vehicle)?;
            let ground = ground_named(&surface)?;
            anyhow::ensure!(
                grade.is_finite() && (0.0..=60.0).contains(&grade),
                "--grade must be degrees in [0, 60]"
            );
            anyhow::ensure!(
                seconds.is_finite() && seconds > 0.0 && seconds <= 60.0,
                "--seconds must be in (0, 60]"
            );
            check_dt(dt)?;
            let setup = sim_core::characterize::Setup { ground, dt };
            println!("t,speed,engine_speed,engine_torque,gear");
            for (t, v, gear) in sim_core::characterize::roll_back(&spec, &setup, grade, seconds) {
                println!("{t:.3},{v:.6},,,{gear}");
            }
        }
        SimCmd::Drive {
            task_dir,
            task,
            planner,
            vehicle,
            release_rules,
        } => super::sim_drive::drive(
            &task_dir.unwrap_or_else(tasks::embedded::default_dir),
            task,
            &planner,
            &vehicle,
            release_rules,
        )?,
        SimCmd::Episodes {
            task_dir,
            reference,
            vehicle,
            json,
        } => super::sim_drive::episodes(
            &task_dir.unwrap_or_else(tasks::embedded::default_dir),
            &reference,
            &vehicle,
            json,
        )?,
        SimCmd::Vehicles => {
            for v in sim_core::vehicle::builtin_vehicles() {
                println!("{:<12} scale {:<8} {}", v.name, v.scale, v.description);
            }
        }
    }
    Ok(())
}

/// `vb sim run`: one episode, its trajectory, plot and result.
fn run_one(a: RunArgs) -> anyhow::Result<()> {
    let RunArgs {
        world,
        task,
        vehicle,
        planner,
        scale,
        task_dir,
        record_hz,
        out,
    } = a;
    anyhow::ensure!(
        record_hz.is_finite() && record_hz > 0.0,
        "--record-hz must be positive"
    );
    let spec = sim_core::vehicle::vehicle_by_name(&vehicle)?;
    let scale = scale.unwrap_or(spec.scale);
    let set = tasks::TaskSet::load(&task_dir.unwrap_or_else(tasks::embedded::default_dir))?;
    let w = set.world(world, scale)?;
    let t = set
        .tasks(world, scale)?
        .into_iter()
        .nth(task as usize)
        .ok_or_else(|| anyhow::anyhow!("world {world} has no task {task} (0..9)"))?;
    let mut p: Box<dyn sim_core::planner::Planner> = match planner.as_str() {
        "pure_pursuit" => Box::new(sim_core::control::PurePursuit::new()),
        other => eval::Builtin::resolve(other, None)?.make(),
    };
    let cfg = EpisodeConfig {
        record_hz: Some(record_hz),
        ..Default::default()
    };
    let r = sim_core::run_episode(&w, &t, &spec, p.as_mut(), &cfg);
    let json = serde_json::to_string_pretty(&serde_json::json!({
        "task": t.id(), "vehicle": spec.name, "scale": scale, "planner": planner,
        "outcome": r.outcome.as_str(), "reason": r.reason, "detail": r.detail, "metrics": r.metrics,
    }))?;
    eval::viz::write_episode(&out, &w, &t, &r, &json)?;
    println!("{}: {} ({}) after {:.1} s, {:.1} m driven; wrote {}/trajectory.csv, episode.png, result.json", t.id(), r.outcome.as_str(), r.reason, r.metrics.time, r.metrics.path_length, out.display());
    Ok(())
}

/// `--surface`: one ground of the datasheet.
fn ground_named(surface: &str) -> anyhow::Result<sim_core::characterize::Ground> {
    sim_core::characterize::Ground::from_name(surface)
        .ok_or_else(|| anyhow::anyhow!("unknown --surface `{surface}` (rigid, snow, mud or sand)"))
}

/// `--dt`, when given: a physics step in (0, 0.02] s.
pub(super) fn check_dt(dt: Option<f64>) -> anyhow::Result<()> {
    anyhow::ensure!(
        dt.is_none_or(|d| d.is_finite() && d > 0.0 && d <= 0.02),
        "--dt must be in (0, 0.02] s"
    );
    Ok(())
}

/// The harness's trace header (tools/chrono-reference/src/scenarios.cpp).
const TRACE_HEADER: &str = "grade_deg,t,wheel,x,z,speed,gear,engine_speed,sinkage,slip,omega,v_fwd,normal,tractive,moment,chassis_normal,chassis_fx,suspension_normal,suspension_fx";

fn climb(
    vehicle: &str,
    surface: &str,
    grades: &[f64],
    dt: Option<f64>,
    trace: Option<&std::path::Path>,
    every: f64,
) -> anyhow::Result<()> {
    use anyhow::Context;
    use sim_core::characterize::Setup;
    use std::io::Write;
    let spec = sim_core::vehicle::vehicle_by_name(vehicle)?;
    let ground = ground_named(surface)?;
    anyhow::ensure!(
        grades
            .iter()
            .all(|g| g.is_finite() && (0.0..=60.0).contains(g)),
        "--grade must be degrees in [0, 60]"
    );
    check_dt(dt)?;
    anyhow::ensure!(
        every.is_finite() && every > 0.0,
        "--every must be a positive number of seconds"
    );
    let mut out = match trace {
        Some(p) => {
            let f =
                std::fs::File::create(p).with_context(|| format!("creating {}", p.display()))?;
            let mut w = std::io::BufWriter::new(f);
            writeln!(w, "{TRACE_HEADER}")?;
            Some((p, w))
        }
        None => None,
    };
    let setup = Setup { ground, dt };
    for &g in grades {
        let mut failed = None;
        let climbed = sim_core::climb_trace::climb_traced(&spec, &setup, g, every, |s| {
            let Some((_, w)) = out.as_mut() else { return };
            if failed.is_some() {
                return;
            }
            let name = sim_core::climb_trace::wheel_name(s.wheel, s.wheels);
            if let Err(e) = writeln!(
                w,
                "{g},{:.3},{name},{:.4},{:.4},{:.4},{},,{:.4},{:.4},{:.4},{:.4},{:.1},{:.1},{},,,,",
                s.t,
                s.x,
                s.z,
                s.speed,
                s.gear,
                s.sinkage,
                s.slip,
                s.omega,
                s.v_fwd,
                s.normal,
                s.tractive,
                s.moment.map_or(String::new(), |m| format!("{m:.1}"))
            ) {
                failed = Some(e);
            }
        });
        if let (Some(e), Some((p, _))) = (failed, &out) {
            return Err(e).with_context(|| format!("writing {}", p.display()));
        }
        println!(
            "{surface} {g} deg: {}",
            if climbed { "climbs" } else { "does not climb" }
        );
    }
    if let Some((p, mut w)) = out {
        w.flush()
            .with_context(|| format!("writing {}", p.display()))?;
        println!("wrote {}", p.display());
    }
    Ok(())
}
