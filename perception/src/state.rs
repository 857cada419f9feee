//! State estimation: what the planner believes the vehicle's state is.
//!
//! The estimated map frame drifts: it turns about the start at `yaw_drift_deg_per_s` (sign drawn per episode) and
//! slides by `drift_share` of the distance travelled (direction drawn per episode), the way odometry's error grows
//! with the path (KITTI's odometry benchmark reports it as a share of distance). On top come white GNSS-like
//! position noise, velocity and angular-rate noise with per-episode biases, and a latency in control steps. Roll
//! and pitch stay true (an IMU observes them from gravity); time and the applied steering are the vehicle's own.

use crate::profile::StateNoise;
use crate::rng::{normal, sign, uniform};
use rand_chacha::ChaCha8Rng;
use sim_core::planner::VehicleState;
use std::collections::VecDeque;

/// One episode's state estimator.
pub struct StateEstimator {
    cfg: StateNoise,
    rng: ChaCha8Rng,
    start: [f64; 2],
    drift_dir: [f64; 2],
    yaw_sign: f64,
    velocity_bias: [f64; 3],
    rate_bias: [f64; 3],
    distance: f64,
    last: Option<[f64; 2]>,
    history: VecDeque<VehicleState>,
}

impl StateEstimator {
    /// `cfg`'s lengths already at the world's scale; `start`: where the map frame is anchored.
    pub fn new(cfg: StateNoise, mut rng: ChaCha8Rng, start: [f64; 2]) -> StateEstimator {
        let angle = std::f64::consts::TAU * uniform(&mut rng);
        let yaw_sign = sign(&mut rng);
        let velocity_bias = [0; 3].map(|_| cfg.velocity_bias * normal(&mut rng));
        let rate_bias = [0; 3].map(|_| cfg.rate_bias_deg.to_radians() * normal(&mut rng));
        StateEstimator {
            history: VecDeque::with_capacity(cfg.latency_steps as usize + 1),
            cfg,
            rng,
            start,
            drift_dir: [angle.cos(), angle.sin()],
            yaw_sign,
            velocity_bias,
            rate_bias,
            distance: 0.0,
            last: None,
        }
    }

    /// Distance travelled so far (horizontal), m.
    pub fn distance(&self) -> f64 {
        self.distance
    }

    /// The map frame's heading error at time `t`, rad.
    pub fn yaw_error(&self, t: f64) -> f64 {
        self.yaw_sign * self.cfg.yaw_drift_deg_per_s.to_radians() * t
    }

    /// The drift of the estimated position (without white noise), m.
    pub fn drift(&self, truth: &VehicleState) -> [f64; 2] {
        let (s, c) = self.yaw_error(truth.time).sin_cos();
        let (dx, dy) = (
            truth.position[0] - self.start[0],
            truth.position[1] - self.start[1],
        );
        let slide = self.cfg.drift_share * self.distance;
        [
            c * dx - s * dy - dx + slide * self.drift_dir[0],
            s * dx + c * dy - dy + slide * self.drift_dir[1],
        ]
    }

    /// Call once per control step with the true state; returns what the planner sees.
    pub fn estimate(&mut self, truth: &VehicleState) -> VehicleState {
        let xy = [truth.position[0], truth.position[1]];
        if let Some(last) = self.last {
            self.distance += (xy[0] - last[0]).hypot(xy[1] - last[1]);
        }
        self.last = Some(xy);
        let c = &self.cfg;
        let drift = self.drift(truth);
        let dyaw = self.yaw_error(truth.time);
        let (s, co) = dyaw.sin_cos();
        let mut est = *truth;
        for (k, d) in drift.iter().enumerate() {
            est.position[k] += d + c.position_sigma * normal(&mut self.rng);
        }
        est.position[2] += c.position_sigma * normal(&mut self.rng);
        est.yaw = wrap(truth.yaw + dyaw);
        let v = truth.velocity;
        let turned = [co * v[0] - s * v[1], s * v[0] + co * v[1], v[2]];
        for (k, t) in turned.iter().enumerate() {
            est.velocity[k] = t + self.velocity_bias[k] + c.velocity_sigma * normal(&mut self.rng);
        }
        let rate_sigma = c.rate_sigma_deg.to_radians();
        for k in 0..3 {
            est.angular_velocity[k] += self.rate_bias[k] + rate_sigma * normal(&mut self.rng);
        }
        est.speed += self.velocity_bias[0] + c.velocity_sigma * normal(&mut self.rng);
        if self.history.len() > c.latency_steps as usize {
            self.history.pop_front();
        }
        self.history.push_back(est);
        // The oldest kept estimate: `latency_steps` ago once the episode is that old.
        self.history.front().copied().unwrap_or(est)
    }
}

fn wrap(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let w = (a + std::f64::consts::PI).rem_euclid(t) - std::f64::consts::PI;
    if w.is_finite() {
        w
    } else {
        a
    }
}
