//! The episode's rules as a referee that watches the chassis' state after every physics step: when the episode
//! ends (success, overturning, leaving the map, stuck, the time limit) and, at its end, whether a failed trial was
//! a rollover under the configured [`RolloverRule`].
//!
//! [`EpisodeRun`](crate::EpisodeRun) owns one; so can a driver of a vehicle simulated elsewhere (`vb sim drive`
//! judges the Chrono reference harness' episodes with it), so both are judged by the same code.

use crate::episode::*;
use crate::planner::VehicleState;
use crate::stuck::StuckWatch;
use crate::world::{Task, World};

/// How an episode ended, before the rollover rule classified a failed trial (`reason` is machine-readable, e.g.
/// `timeout`, `off_map`, `invalid_action`).
#[derive(Clone, Debug, PartialEq)]
pub struct EpisodeEnd {
    pub outcome: Outcome,
    pub reason: EndReason,
    pub detail: String,
}

impl EpisodeEnd {
    pub fn new(outcome: Outcome, reason: EndReason, detail: impl Into<String>) -> EpisodeEnd {
        EpisodeEnd {
            outcome,
            reason,
            detail: detail.into(),
        }
    }
}

/// The termination rules of one episode and what they remember (the stuck rule's window, the largest |roll| and
/// |pitch| so far).
#[derive(Clone, Debug)]
pub struct Referee {
    goal: [f64; 2],
    /// Success radius at the world's scale, m.
    goal_radius: f64,
    /// The map's half extents, m.
    half: [f64; 2],
    max_time: f64,
    rollover_deg: f64,
    rollover: RolloverRule,
    stuck: StuckWatch,
    /// Largest |roll| and |pitch| after any step so far, degrees.
    roll_max: f64,
    pitch_max: f64,
}

impl Referee {
    /// The rules `cfg` for `task` in `world`, for a vehicle stepped every `dt` seconds.
    pub fn new(world: &World, task: &Task, cfg: &EpisodeConfig, dt: f64) -> Referee {
        let scale = world.scale;
        Referee {
            goal: task.goal,
            goal_radius: cfg.goal_radius * scale,
            half: [world.heightmap.half_x(), world.heightmap.half_y()],
            max_time: cfg.max_time,
            rollover_deg: cfg.rollover_deg,
            rollover: cfg.rollover,
            stuck: StuckWatch::new(cfg.stuck, scale, dt),
            roll_max: 0.0,
            pitch_max: 0.0,
        }
    }

    /// After physics step `step` (counted from 1), with the vehicle in state `s` (`s.position` the chassis'
    /// reference point): how the episode ended, if it has. The rules, in order: a diverged simulation, success
    /// (horizontal distance within the goal radius), |roll| past the threshold under [`RolloverRule::Immediate`],
    /// overturning (the chassis' up axis below the horizon), leaving the map, stuck, the time limit.
    pub fn check(&mut self, step: u64, s: &VehicleState) -> Option<EpisodeEnd> {
        use Outcome::*;
        let pos = s.position;
        let (r, p) = (s.roll.to_degrees(), s.pitch.to_degrees());
        self.roll_max = self.roll_max.max(r.abs());
        self.pitch_max = self.pitch_max.max(p.abs());
        if !(pos[0].is_finite() && pos[1].is_finite() && pos[2].is_finite()) {
            return Some(EpisodeEnd::new(
                Rollover,
                EndReason::NumericalFailure,
                "the simulation diverged",
            ));
        }
        if (pos[0] - self.goal[0]).hypot(pos[1] - self.goal[1]) < self.goal_radius {
            return Some(EpisodeEnd::new(Success, EndReason::Success, ""));
        }
        if self.rollover == RolloverRule::Immediate && r.abs() > self.rollover_deg {
            let d = format!("|roll| = {:.1} deg", r.abs());
            return Some(EpisodeEnd::new(Rollover, EndReason::Rollover, d));
        }
        // Body z-axis in the world (R = Rz(yaw) Ry(pitch) Rx(roll)): its vertical component is cos(pitch) cos(roll).
        let up_z = s.pitch.cos() * s.roll.cos();
        if up_z < 0.0 {
            let tilt = up_z.acos().to_degrees();
            let d = format!("overturned: chassis tilted {tilt:.0} deg (roll {r:.0}, pitch {p:.0})");
            return Some(EpisodeEnd::new(Rollover, EndReason::Rollover, d));
        }
        if pos[0].abs() > self.half[0] || pos[1].abs() > self.half[1] {
            return Some(EpisodeEnd::new(OffMap, EndReason::OffMap, ""));
        }
        if let Some(d) = self.stuck.check(step, s.time, [pos[0], pos[1]], s.speed) {
            return Some(EpisodeEnd::new(Stuck, EndReason::Stuck, d));
        }
        if s.time >= self.max_time {
            return Some(EpisodeEnd::new(Timeout, EndReason::Timeout, ""));
        }
        None
    }

    /// Whether the rollover rule makes an end of `outcome` a rollover, the vehicle's final roll being `end_roll`
    /// (rad): a failed trial (stuck or timed out, not cancelled) whose final |roll| (or largest |roll| or |pitch|,
    /// under the release's rule) exceeds the threshold.
    pub fn rolled_over(&self, outcome: Outcome, end_roll: f64) -> bool {
        let failed = matches!(outcome, Outcome::Stuck | Outcome::Timeout);
        let thr = self.rollover_deg;
        failed
            && match self.rollover {
                RolloverRule::AtFailure => end_roll.to_degrees().abs() > thr,
                RolloverRule::MaxDuringFailure => self.roll_max.max(self.pitch_max) > thr,
                RolloverRule::Immediate => false,
            }
    }

    /// Applies the rollover rule to how the episode ended (the vehicle's final roll `end_roll`, rad): a failed trial
    /// it makes a rollover gets that outcome and a detail saying why; everything else is unchanged.
    pub fn classify(&self, end: EpisodeEnd, end_roll: f64) -> (Outcome, EndReason, String) {
        let EpisodeEnd {
            outcome,
            reason,
            detail,
        } = end;
        if !self.rolled_over(outcome, end_roll) {
            return (outcome, reason, detail);
        }
        let what = if detail.is_empty() {
            reason.to_string()
        } else {
            format!("{reason}: {detail}")
        };
        let detail = if self.rollover == RolloverRule::AtFailure {
            let end_roll = end_roll.to_degrees().abs();
            format!("|roll| = {end_roll:.1} deg at the end of a failed trial ({what})")
        } else {
            let (roll_max, pitch_max) = (self.roll_max, self.pitch_max);
            format!(
                "max |roll| {roll_max:.1} deg, max |pitch| {pitch_max:.1} deg during a failed trial ({what})"
            )
        };
        (Outcome::Rollover, EndReason::Rollover, detail)
    }
}
