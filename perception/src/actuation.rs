//! Actuation: what the vehicle applies when the planner commands an action. A command reaches the vehicle
//! `latency_steps` control steps late (the vehicle holds still before the first arrives), steering carries a bias
//! (sign drawn per episode), throttle a gain (drawn per episode), and steering and throttle follow a first-order lag
//! at the control rate.

use crate::profile::ActuationNoise;
use crate::rng::{sign, uniform};
use rand_chacha::ChaCha8Rng;
use sim_core::planner::Action;
use std::collections::VecDeque;

/// One episode's actuator.
pub struct Actuator {
    queue: VecDeque<Action>,
    latency: usize,
    /// Steering bias, normalised steering units.
    bias: f64,
    gain: f64,
    /// Share of the gap closed per control step, `1 - exp(-dt / lag)` (1: no lag).
    alpha: f64,
    applied: Action,
}

impl Actuator {
    /// `max_steer`: the vehicle's largest road-wheel angle, rad (a skid-steered vehicle, 0, reads the bias against
    /// 30 degrees); `control_dt`: the planner's control period, s.
    pub fn new(
        cfg: &ActuationNoise,
        mut rng: ChaCha8Rng,
        max_steer: f64,
        control_dt: f64,
    ) -> Actuator {
        let full = if max_steer > 0.0 {
            max_steer
        } else {
            30f64.to_radians()
        };
        let bias = sign(&mut rng) * cfg.steering_bias_deg.to_radians() / full;
        let gain = 1.0 + cfg.throttle_gain_spread * (2.0 * uniform(&mut rng) - 1.0);
        let alpha = if cfg.lag_s > 0.0 {
            1.0 - (-control_dt / cfg.lag_s).exp()
        } else {
            1.0
        };
        Actuator {
            queue: VecDeque::with_capacity(cfg.latency_steps as usize + 1),
            latency: cfg.latency_steps as usize,
            bias,
            gain,
            alpha,
            applied: Action::default(),
        }
    }

    /// The per-episode steering bias (normalised) and throttle gain.
    pub fn bias_and_gain(&self) -> (f64, f64) {
        (self.bias, self.gain)
    }

    /// The action the vehicle applies for this control step, given the planner's command.
    pub fn apply(&mut self, command: Action) -> Action {
        self.queue.push_back(command);
        let arrived = if self.queue.len() > self.latency {
            self.queue.pop_front().unwrap_or_default()
        } else {
            Action::default()
        };
        let target = Action {
            steering: (arrived.steering + self.bias).clamp(-1.0, 1.0),
            throttle: (arrived.throttle * self.gain).clamp(-1.0, 1.0),
            brake: arrived.brake,
        };
        let a = self.alpha;
        if a >= 1.0 {
            self.applied = target;
            return target;
        }
        self.applied = Action {
            steering: self.applied.steering + a * (target.steering - self.applied.steering),
            throttle: self.applied.throttle + a * (target.throttle - self.applied.throttle),
            brake: target.brake,
        };
        self.applied
    }
}
