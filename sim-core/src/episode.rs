//! Episode definitions: termination rules, outcomes and per-episode metrics.
//!
//! The runner itself (`run_episode`) lives next to the vehicle dynamics; these are the types every consumer (local
//! evaluator, service worker, leaderboard conversions) shares.

use serde::{Deserialize, Serialize};

// Shared with every crate that reads results (the service, the evaluator's reports) without the simulator.
pub use contracts::{EndReason, EpisodeMetrics, Outcome, Rules, SignalStats, TrajectorySample};

/// How "stuck" is decided.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "rule", rename_all = "snake_case")]
pub enum StuckRule {
    /// Stuck when the vehicle moved less than `distance` (full-scale m, scaled with the world) during the last
    /// `window` seconds. The default (paper definition).
    Displacement { distance: f64, window: f64 },
    /// The original release's rule: speed below `speed` (m/s, unscaled) continuously for `window` seconds.
    Speed { speed: f64, window: f64 },
}

/// When a tilted vehicle counts as rolled over.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RolloverRule {
    /// The paper's definition (default): a trial fails by getting stuck or timing out, and a failed trial whose
    /// final |roll| exceeds the threshold is a rollover. A vehicle that overturns (its chassis up-axis below the
    /// horizon) ends the episode at once as a rollover: it cannot recover, and waiting for "stuck" only costs time.
    /// A vehicle that leans past the threshold on a side slope and drives on is not failed for it.
    #[default]
    AtFailure,
    /// The original release's post-hoc classification: a failed trial whose maximum |roll| or |pitch| during the
    /// episode exceeded the threshold is a rollover (also ends at once on overturning).
    MaxDuringFailure,
    /// End the episode as soon as |roll| exceeds the threshold (the strict rule vertibench used before the
    /// task-set evaluation showed it fails transient side-slope leans far below the vehicle's tipping angle).
    Immediate,
}

/// Termination rules and recording options of an episode. Lengths are full-scale and get multiplied by the
/// world's scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeConfig {
    /// Success radius around the goal, full-scale m (paper: 10 m; original release: 8 m).
    pub goal_radius: f64,
    /// Time limit, s.
    pub max_time: f64,
    /// Rollover threshold on |roll|, degrees (how it is applied: `rollover`).
    pub rollover_deg: f64,
    /// When the threshold makes a rollover.
    #[serde(default)]
    pub rollover: RolloverRule,
    pub stuck: StuckRule,
    /// Trajectory recording rate, Hz (`None`: no trajectory).
    pub record_hz: Option<f64>,
    /// Seed for everything random inside the episode (none of the default physics is random).
    pub seed: u64,
}

impl Default for EpisodeConfig {
    fn default() -> Self {
        EpisodeConfig {
            goal_radius: 10.0,
            max_time: 60.0,
            rollover_deg: 30.0,
            rollover: RolloverRule::AtFailure,
            stuck: StuckRule::Displacement {
                distance: 1.0,
                window: 10.0,
            },
            record_hz: None,
            seed: 0,
        }
    }
}

impl EpisodeConfig {
    /// The named rules this configuration follows (the seed and the trajectory recording do not count).
    pub fn rules(&self) -> Rules {
        let plain = EpisodeConfig {
            seed: 0,
            record_hz: None,
            ..self.clone()
        };
        if plain == EpisodeConfig::default() {
            Rules::Paper
        } else if plain == EpisodeConfig::release() {
            Rules::Release
        } else {
            Rules::Custom
        }
    }

    /// The original release's rules: 8 m goal radius, speed-based stuck (below 2 m/s for 10 s) and its post-hoc
    /// rollover classification (a failed trial whose |roll| or |pitch| ever exceeded 30 degrees).
    pub fn release() -> Self {
        EpisodeConfig {
            goal_radius: 8.0,
            rollover: RolloverRule::MaxDuringFailure,
            stuck: StuckRule::Speed {
                speed: 2.0,
                window: 10.0,
            },
            ..EpisodeConfig::default()
        }
    }
}

/// Everything an episode produces.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EpisodeResult {
    pub outcome: Outcome,
    /// Why it ended, finer than `outcome` (the planner's failures told apart).
    pub reason: EndReason,
    /// Human-readable detail (e.g. the planner's error message).
    pub detail: String,
    pub metrics: EpisodeMetrics,
    pub trajectory: Vec<TrajectorySample>,
}

/// Running mean / variance / max (Welford).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Running {
    n: f64,
    mean: f64,
    m2: f64,
    pub(crate) max: f64,
}

impl Running {
    pub(crate) fn push(&mut self, v: f64) {
        if self.n == 0.0 {
            self.max = v;
        }
        self.n += 1.0;
        let d = v - self.mean;
        self.mean += d / self.n;
        self.m2 += d * (v - self.mean);
        self.max = self.max.max(v);
    }
    pub(crate) fn stats(&self) -> SignalStats {
        SignalStats {
            mean: self.mean,
            var: if self.n > 0.0 { self.m2 / self.n } else { 0.0 },
            max: self.max,
        }
    }
}
