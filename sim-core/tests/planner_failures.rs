//! A planner that fails, returns NaN or out-of-range actions, or has a bad control rate fails its episode with a
//! stated reason; the episode runner never panics.

mod common;
use common::*;
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::Task;

/// What a scripted planner returns once it starts failing.
type Failure = fn() -> Result<Action, PlannerError>;

struct Scripted {
    rate: f64,
    step: usize,
    fail_at: usize,
    failure: Failure,
}

impl Planner for Scripted {
    fn name(&self) -> &str {
        "scripted"
    }
    fn control_rate_hz(&self) -> f64 {
        self.rate
    }
    fn reset(&mut self, _: &PlannerContext<'_>) -> Result<(), PlannerError> {
        Ok(())
    }
    fn act(&mut self, _: &Observation) -> Result<Action, PlannerError> {
        self.step += 1;
        if self.step >= self.fail_at {
            (self.failure)()
        } else {
            Ok(Action {
                steering: 0.0,
                throttle: 0.4,
                brake: 0.0,
            })
        }
    }
}

fn run(
    rate: f64,
    failure: fn() -> Result<Action, PlannerError>,
) -> sim_core::episode::EpisodeResult {
    let w = flat(0.8);
    let task = Task {
        world_id: 1,
        index: 0,
        start: [-50.0, 0.0],
        goal: [50.0, 0.0],
        path: vec![[-50.0, 0.0], [50.0, 0.0]],
    };
    let mut p = Scripted {
        rate,
        step: 0,
        fail_at: 20,
        failure,
    };
    sim_core::run_episode(
        &w,
        &task,
        &vehicle_by_name("hmmwv").unwrap(),
        &mut p,
        &EpisodeConfig::default(),
    )
}

#[test]
fn planner_failures_end_the_episode_with_their_reason() {
    let cases: [(Failure, &str); 5] = [
        (
            || {
                Ok(Action {
                    steering: f64::NAN,
                    throttle: 0.0,
                    brake: 0.0,
                })
            },
            "invalid_action",
        ),
        (
            || {
                Ok(Action {
                    steering: 0.0,
                    throttle: 3.0,
                    brake: 0.0,
                })
            },
            "invalid_action",
        ),
        (
            || Err(PlannerError::Timeout("no answer within 1 s".into())),
            "planner_timeout",
        ),
        (
            || Err(PlannerError::Crashed("exit code 139".into())),
            "planner_crash",
        ),
        (
            || Err(PlannerError::Protocol("garbled".into())),
            "planner_protocol",
        ),
    ];
    for (failure, reason) in cases {
        let r = run(20.0, failure);
        assert_eq!(r.outcome, Outcome::PlannerFailure);
        assert_eq!(r.reason.as_str(), reason);
        assert!(!r.detail.is_empty());
        // It failed at its 20th action, after 19 control periods of driving normally.
        let dt = sim_core::vehicle::default_dt(1.0);
        let expected = 19.0 * (0.05 / dt).round() * dt;
        assert!(
            (r.metrics.time - expected).abs() < 1e-9,
            "{} vs {expected}",
            r.metrics.time
        );
    }
    for rate in [0.0, f64::NAN, -5.0] {
        let r = run(rate, || Ok(Action::default()));
        assert_eq!(
            (r.outcome, r.reason.as_str()),
            (Outcome::PlannerFailure, "planner_error")
        );
    }
}
