//! Reward terms for learning agents (the Python SDK's environments and the `Sim` gRPC API share them).
//!
//! `reward = progress + roll + pitch + terminal`, with
//! - `progress = w_progress * (decrease of the horizontal goal distance over the step) / world scale` (m at full
//!   scale; negative when the vehicle moves away),
//! - `roll = -w_roll * (roll / rollover threshold)^2` and `pitch = -w_pitch * (pitch / rollover threshold)^2` at
//!   the end of the step: penalties, never positive,
//! - `terminal = +success_bonus` on success, `-failure_penalty` when the episode ends any other way except the time
//!   limit, 0 otherwise.
//!
//! An episode that ends at the time limit is *truncated* (gymnasium's sense: the task itself did not end); every
//! other end is *terminated*.

use crate::episode::Outcome;
use crate::episode_run::EpisodeEnd;

/// Weights of the reward terms.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RewardWeights {
    pub progress: f64,
    pub roll: f64,
    pub pitch: f64,
    pub success_bonus: f64,
    pub failure_penalty: f64,
}

impl Default for RewardWeights {
    fn default() -> Self {
        RewardWeights {
            progress: 1.0,
            roll: 0.1,
            pitch: 0.1,
            success_bonus: 10.0,
            failure_penalty: 10.0,
        }
    }
}

/// The terms of one step's reward.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RewardTerms {
    pub progress: f64,
    pub roll: f64,
    pub pitch: f64,
    pub terminal: f64,
}

impl RewardTerms {
    pub fn total(&self) -> f64 {
        self.progress + self.roll + self.pitch + self.terminal
    }
    pub fn as_array(&self) -> [f64; 4] {
        [self.progress, self.roll, self.pitch, self.terminal]
    }
}

/// Whether an end is the time limit (truncation) rather than an end of the task (termination).
pub fn is_time_limit(end: &EpisodeEnd) -> bool {
    end.reason.is_time_limit()
}

impl RewardWeights {
    /// The terms of a step that moved the vehicle from `distance_before` to `distance_after` from the goal and left
    /// it at `roll` and `pitch` (rad); `rollover_deg` is the episode's threshold, `scale` the world's. `end` and
    /// `outcome` (after the rollover rule) give the terminal term of the step that ended the episode.
    #[allow(clippy::too_many_arguments)]
    pub fn terms(
        &self,
        distance_before: f64,
        distance_after: f64,
        roll: f64,
        pitch: f64,
        rollover_deg: f64,
        scale: f64,
        end: Option<(&EpisodeEnd, Outcome)>,
    ) -> RewardTerms {
        let limit = rollover_deg.to_radians();
        let terminal = match end {
            None => 0.0,
            Some((_, Outcome::Success)) => self.success_bonus,
            Some((e, _)) if is_time_limit(e) => 0.0,
            Some(_) => -self.failure_penalty,
        };
        RewardTerms {
            progress: self.progress * (distance_before - distance_after) / scale,
            roll: -self.roll * (roll / limit).powi(2),
            pitch: -self.pitch * (pitch / limit).powi(2),
            terminal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::episode::EndReason;

    #[test]
    fn terms_have_their_documented_signs_and_sizes() {
        let w = RewardWeights::default();
        let r = w.terms(10.0, 9.0, 0.1, -0.2, 30.0, 0.5, None);
        assert!((r.progress - 2.0).abs() < 1e-12, "1 m at scale 1/2 is 2 m");
        let lim = 30f64.to_radians();
        assert!((r.roll + 0.1 * (0.1 / lim).powi(2)).abs() < 1e-12);
        assert!((r.pitch + 0.1 * (0.2 / lim).powi(2)).abs() < 1e-12);
        let end = |reason| EpisodeEnd {
            outcome: Outcome::Timeout,
            reason,
            detail: String::new(),
        };
        let t = end(EndReason::Timeout);
        assert_eq!(
            w.terms(1.0, 1.0, 0.0, 0.0, 30.0, 1.0, Some((&t, Outcome::Timeout)))
                .terminal,
            0.0
        );
        // A timed-out trial classified as a rollover is still truncated, but it failed the task.
        assert_eq!(
            w.terms(1.0, 1.0, 0.0, 0.0, 30.0, 1.0, Some((&t, Outcome::Rollover)))
                .terminal,
            0.0
        );
        let s = end(EndReason::Stuck);
        assert_eq!(
            w.terms(1.0, 1.0, 0.0, 0.0, 30.0, 1.0, Some((&s, Outcome::Stuck)))
                .terminal,
            -10.0
        );
        let ok = end(EndReason::Success);
        assert_eq!(
            w.terms(1.0, 1.0, 0.0, 0.0, 30.0, 1.0, Some((&ok, Outcome::Success)))
                .terminal,
            10.0
        );
    }
}
