//! The rollover rules of an episode, on real physics: a braked HMMWV parked across a side slope.
//!
//! Default (the paper's definition): a failed trial whose final |roll| exceeds 30 degrees is a rollover, a vehicle
//! that overturns ends at once as a rollover, and a lean past 30 degrees alone fails nothing. `Immediate` is the
//! strict rule (fail the moment |roll| passes 30 degrees), `MaxDuringFailure` the original release's post-hoc
//! classification.

mod common;
use common::*;
use sim_core::episode::{EpisodeConfig, EpisodeResult, Outcome, RolloverRule};
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::{Task, World};

/// Holds the brakes; never moves.
struct Parked;

impl Planner for Parked {
    fn name(&self) -> &str {
        "parked"
    }
    fn control_rate_hz(&self) -> f64 {
        10.0
    }
    fn reset(&mut self, _: &PlannerContext<'_>) -> Result<(), PlannerError> {
        Ok(())
    }
    fn act(&mut self, _: &Observation) -> Result<Action, PlannerError> {
        Ok(action(0.0, 0.0, 1.0))
    }
}

/// Heading along +x across a slope rising along +y: the vehicle's roll is the slope angle.
fn across(world: &World, rule: RolloverRule) -> EpisodeResult {
    let task = Task {
        world_id: 1,
        index: 0,
        start: [-30.0, 0.0],
        goal: [30.0, 0.0],
        path: vec![[-30.0, 0.0], [30.0, 0.0]],
    };
    let cfg = EpisodeConfig {
        rollover: rule,
        ..EpisodeConfig::default()
    };
    sim_core::run_episode(
        world,
        &task,
        &vehicle_by_name("hmmwv").unwrap(),
        &mut Parked,
        &cfg,
    )
}

#[test]
fn a_lean_past_30_degrees_fails_only_a_trial_that_failed_anyway() {
    // 36 degrees: past the 30 degree threshold, below the HMMWV's tipping angle (about 45-52 degrees) and the
    // sliding angle (atan 1.0 = 45 degrees), so the braked vehicle stays put, leaning.
    let w = slope_y(36.0, 1.0);

    let strict = across(&w, RolloverRule::Immediate);
    assert_eq!(strict.outcome, Outcome::Rollover, "{strict:?}");
    assert!(
        strict.metrics.time < 2.0,
        "ended at {} s",
        strict.metrics.time
    );

    // The paper's rule: the trial fails by getting stuck (10 s without moving 1 m), and as it ends leaning past
    // 30 degrees it is a rollover.
    let paper = across(&w, RolloverRule::AtFailure);
    assert_eq!(paper.outcome, Outcome::Rollover, "{paper:?}");
    assert_eq!(paper.reason, sim_core::episode::EndReason::Rollover);
    assert!(
        paper.detail.contains("at the end of a failed trial") && paper.detail.contains("stuck"),
        "{}",
        paper.detail
    );
    assert!(
        paper.metrics.time >= 10.0,
        "ended at {} s",
        paper.metrics.time
    );

    let release = across(&w, RolloverRule::MaxDuringFailure);
    assert_eq!(release.outcome, Outcome::Rollover, "{release:?}");
    assert!(release.detail.contains("during a failed trial"));
}

#[test]
fn a_failed_trial_on_a_gentle_side_slope_is_stuck_not_a_rollover() {
    let w = slope_y(20.0, 1.0);
    for rule in [
        RolloverRule::AtFailure,
        RolloverRule::MaxDuringFailure,
        RolloverRule::Immediate,
    ] {
        let r = across(&w, rule);
        assert_eq!(r.outcome, Outcome::Stuck, "{rule:?}: {r:?}");
        assert!(r.metrics.roll_abs.max > 15.0 && r.metrics.roll_abs.max < 30.0);
    }
}

#[test]
fn an_overturned_vehicle_ends_the_episode_at_once_as_a_rollover() {
    // On a plain 60 degree slope the HMMWV slides before it tips (friction 1.0 is below its track width over twice
    // its centre-of-mass height, about 1.3). A kerb at the downhill side stops the slide, and at 60 degrees,
    // past the tipping angle, the vehicle falls over it.
    let t = 60f64.to_radians().tan();
    let kerb = -2.0;
    let w = world_with(
        move |_, y| if y > kerb { y * t } else { kerb * t + 0.8 },
        sim_core::world::Surface::Rigid { friction: 1.0 },
    );
    let r = across(&w, RolloverRule::AtFailure);
    assert_eq!(r.outcome, Outcome::Rollover, "{r:?}");
    assert!(r.detail.contains("overturned"), "{}", r.detail);
    assert!(r.metrics.time < 10.0, "ended at {} s", r.metrics.time);
}
