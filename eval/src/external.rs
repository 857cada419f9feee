//! A built-in planner driving a vehicle simulated elsewhere, judged by the benchmark's own rules
//! ([`sim_core::referee::Referee`]): `vb sim drive` speaks this protocol to the Chrono reference harness
//! (`chrono-reference episodes`, issue 59 item 4), so Chrono's HMMWV is driven by the very planner code and judged by
//! the very rules that judge sim-core's.
//!
//! The protocol is lock-step text over a pipe: every line the simulator writes gets exactly one line back.
//!
//! ```text
//! simulator: dt 0.005                          (its physics step, s; first)
//! driver:    ok {"planner": "pid", "config": {...the EpisodeConfig...}, "control_every": 10}
//! simulator: state T X Y Z ROLL PITCH YAW VX VY VZ WX WY WZ SPEED STEERING
//!            (after settling, T = 0; then after every physics step: `VehicleState`'s fields in its units and
//!            frames, X Y Z the chassis' reference point, angles Cardan Rz(yaw) Ry(pitch) Rx(roll))
//! driver:    act STEERING THROTTLE BRAKE       (on a control step: the inputs from now on)
//!      or:   same                              (between control steps: the inputs stay)
//!      or:   end {"outcome": "success", "reason": "success", "detail": "", "time": 23.4, ...}
//! ```
//!
//! The planner acts on the first state and then every `control_every` physics steps, as in
//! [`sim_core::EpisodeRun`]; the rules are checked after every physics step; after `end` the driver returns.

use serde::Serialize;
use sim_core::episode::{EndReason, EpisodeConfig, Outcome};
use sim_core::planner::{Observation, Planner, PlannerContext, VehicleState};
use sim_core::referee::{EpisodeEnd, Referee};
use sim_core::runner::control_every;
use sim_core::vehicle::VehicleSpec;
use sim_core::world::{Task, World};
use std::io::{BufRead, Write};

/// Why the exchange failed (the episode has no result then).
#[derive(Debug, thiserror::Error)]
pub enum DriveError {
    #[error("line {line} from the simulator: {why}")]
    Protocol { line: usize, why: String },
    #[error("the simulator closed the pipe after {0} lines, before the episode ended")]
    Closed(usize),
    #[error("the pipe to the simulator: {0}")]
    Io(#[from] std::io::Error),
}

/// How the externally simulated episode ended, as the `end` line reports it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ExternalEnd {
    pub outcome: Outcome,
    pub reason: EndReason,
    pub detail: String,
    /// Simulated time at the end, s.
    pub time: f64,
    /// Physics steps run.
    pub steps: u64,
    /// Horizontal distance driven, m.
    pub path_length: f64,
    /// Horizontal distance from the goal at the end, m.
    pub final_goal_distance: f64,
}

/// What the driver says it is (the `ok` line): enough to rerun the same episodes in sim-core.
#[derive(Clone, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct DriverIdentity {
    pub planner: String,
    pub config: EpisodeConfig,
    pub control_every: u64,
}

/// Reads lines, counting them; a closed pipe is an error (the episode had not ended).
struct Lines<R> {
    input: R,
    line: usize,
    buf: String,
}

impl<R: BufRead> Lines<R> {
    fn next(&mut self) -> Result<&str, DriveError> {
        self.buf.clear();
        if self.input.read_line(&mut self.buf)? == 0 {
            return Err(DriveError::Closed(self.line));
        }
        self.line += 1;
        Ok(self.buf.trim())
    }

    fn error(&self, why: impl Into<String>) -> DriveError {
        DriveError::Protocol {
            line: self.line,
            why: why.into(),
        }
    }
}

/// The physics step of a `dt S` line.
fn parse_dt(line: &str) -> Result<f64, String> {
    let dt = match line.split_whitespace().collect::<Vec<_>>()[..] {
        ["dt", v] => v
            .parse::<f64>()
            .map_err(|_| format!("`{v}` is not a number"))?,
        _ => return Err(format!("expected `dt SECONDS`, got `{line}`")),
    };
    if dt.is_finite() && dt > 0.0 && dt <= 0.02 {
        Ok(dt)
    } else {
        Err(format!("the step {dt} s is not in (0, 0.02]"))
    }
}

/// The vehicle state of a `state ...` line (15 numbers).
pub fn parse_state(line: &str) -> Result<VehicleState, String> {
    let mut words = line.split_whitespace();
    if words.next() != Some("state") {
        return Err(format!("expected `state` and 15 numbers, got `{line}`"));
    }
    let mut v = [0.0f64; 15];
    let mut n = 0;
    for w in words {
        if n == v.len() {
            return Err("more than 15 numbers after `state`".into());
        }
        v[n] = w.parse().map_err(|_| format!("`{w}` is not a number"))?;
        n += 1;
    }
    if n < v.len() {
        return Err(format!("{n} numbers after `state`, not 15"));
    }
    if v[0].is_nan() || v[0] < 0.0 {
        return Err(format!("time {} is not a time", v[0]));
    }
    Ok(VehicleState {
        time: v[0],
        position: [v[1], v[2], v[3]],
        roll: v[4],
        pitch: v[5],
        yaw: v[6],
        velocity: [v[7], v[8], v[9]],
        angular_velocity: [v[10], v[11], v[12]],
        speed: v[13],
        steering: v[14],
    })
}

/// Drives one episode of `task` in `world` over the protocol (module documentation): `planner` acts, `cfg`'s rules
/// judge, the simulator on the other end of `input` and `output` moves the vehicle `spec`.
pub fn drive(
    input: impl BufRead,
    mut output: impl Write,
    world: &World,
    task: &Task,
    spec: &VehicleSpec,
    planner: &mut dyn Planner,
    cfg: &EpisodeConfig,
) -> Result<ExternalEnd, DriveError> {
    let mut lines = Lines {
        input,
        line: 0,
        buf: String::new(),
    };
    let dt = parse_dt(lines.next()?).map_err(|why| lines.error(why))?;
    let mut referee = Referee::new(world, task, cfg, dt);
    let info = spec.info();
    let ctx = PlannerContext {
        world,
        task,
        vehicle: &info,
        spec,
        sim_dt: dt,
        believed: false,
    };
    let rate = planner.control_rate_hz();
    let identity = DriverIdentity {
        planner: planner.name().to_string(),
        config: cfg.clone(),
        control_every: control_every(rate, dt),
    };
    let ok = serde_json::to_string(&identity).expect("an identity serialises");
    writeln!(output, "ok {ok}")?;
    output.flush()?;
    let mut at_start = reset(planner, &ctx, rate);
    let mut step = 0u64;
    let mut path_length = 0.0;
    let mut last: Option<VehicleState> = None;
    loop {
        let s = parse_state(lines.next()?).map_err(|why| lines.error(why))?;
        if let Some(prev) = &last {
            if s.time < prev.time {
                return Err(lines.error(format!("time went back from {} to {}", prev.time, s.time)));
            }
            // As EpisodeRun sums it (the horizontal displacement's norm).
            let (dx, dy) = (
                s.position[0] - prev.position[0],
                s.position[1] - prev.position[1],
            );
            path_length += (dx * dx + dy * dy).sqrt();
        }
        let mut end = at_start.take();
        if end.is_none() && step > 0 {
            end = referee.check(step, &s);
        }
        if end.is_none() && step.is_multiple_of(identity.control_every) {
            end = act(planner, &s, &mut output)?;
        } else if end.is_none() {
            writeln!(output, "same")?;
        }
        if let Some(end) = end {
            let result = finish(&referee, task, end, &s, step, path_length);
            let json = serde_json::to_string(&result).expect("an end serialises");
            writeln!(output, "end {json}")?;
            output.flush()?;
            return Ok(result);
        }
        output.flush()?;
        last = Some(s);
        step += 1;
    }
}

/// Resets the planner for the episode; how the episode ends at once if it cannot start (a failed reset, a control
/// rate that is not positive), as in [`sim_core::run_episode`].
fn reset(planner: &mut dyn Planner, ctx: &PlannerContext<'_>, rate: f64) -> Option<EpisodeEnd> {
    let failed = |reason, detail| Some(EpisodeEnd::new(Outcome::PlannerFailure, reason, detail));
    if let Err(e) = planner.reset(ctx) {
        return failed(e.reason(), e.to_string());
    }
    if !(rate.is_finite() && rate > 0.0) {
        return failed(
            EndReason::PlannerError,
            format!("control rate {rate} Hz is not positive"),
        );
    }
    None
}

/// A control step: the planner acts on `s` and its inputs go out as `act`; or the episode ends as a planner
/// failure (an error, an invalid action), as [`sim_core::EpisodeRun::control`] ends it.
fn act(
    planner: &mut dyn Planner,
    s: &VehicleState,
    output: &mut impl Write,
) -> Result<Option<EpisodeEnd>, DriveError> {
    let failed = |reason, detail| {
        Ok(Some(EpisodeEnd::new(
            Outcome::PlannerFailure,
            reason,
            detail,
        )))
    };
    match planner.act(&Observation {
        state: *s,
        belief: None,
    }) {
        Ok(a) => match a.validate() {
            Ok(()) => {
                writeln!(output, "act {} {} {}", a.steering, a.throttle, a.brake)?;
                Ok(None)
            }
            Err(msg) => failed(EndReason::InvalidAction, msg),
        },
        Err(e) => failed(e.reason(), e.to_string()),
    }
}

/// The episode's result: its end classified by the rollover rule on the last state `s`.
fn finish(
    referee: &Referee,
    task: &Task,
    end: EpisodeEnd,
    s: &VehicleState,
    steps: u64,
    path_length: f64,
) -> ExternalEnd {
    let (outcome, reason, detail) = referee.classify(end, s.roll);
    let (gx, gy) = (task.goal[0] - s.position[0], task.goal[1] - s.position[1]);
    ExternalEnd {
        outcome,
        reason,
        detail,
        time: s.time,
        steps,
        path_length,
        final_goal_distance: gx.hypot(gy),
    }
}
