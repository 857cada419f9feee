//! `EpisodeRun::advance` reports each control period's reward terms (the same formula as
//! `RewardWeights::terms` on the goal distances before and after), and `truncated` only at the time limit.

mod common;
use common::*;
use sim_core::episode::{EpisodeConfig, Outcome};
use sim_core::reward::RewardWeights;
use sim_core::vehicle::vehicle_by_name;
use sim_core::world::Task;
use sim_core::EpisodeRun;

#[test]
fn advance_reports_the_reward_of_its_period_and_truncates_at_the_time_limit() {
    let w = flat(0.8);
    let task = Task {
        world_id: 1,
        index: 0,
        start: [-20.0, 0.0],
        goal: [50.0, 0.0],
        path: vec![[-20.0, 0.0], [50.0, 0.0]],
    };
    let spec = vehicle_by_name("hmmwv").unwrap();
    let cfg = EpisodeConfig {
        max_time: 3.0,
        ..EpisodeConfig::default()
    };
    let weights = RewardWeights {
        progress: 2.0,
        ..RewardWeights::default()
    };
    let mut run = EpisodeRun::new(&w, &task, &spec, &cfg);
    run.set_reward_weights(weights);
    let mut before = run.goal_distance();
    let mut periods = 0;
    loop {
        run.control(action(0.6, 0.1, 0.0)).unwrap();
        let step = run.advance();
        let (after, s) = (run.goal_distance(), run.state());
        let end = run.end().cloned();
        let want = weights.terms(
            before,
            after,
            s.roll,
            s.pitch,
            cfg.rollover_deg,
            w.scale,
            end.as_ref().map(|e| (e, e.outcome)),
        );
        assert_eq!(step.reward, want, "period {periods}");
        before = after;
        periods += 1;
        if step.ended() {
            assert!(step.truncated && !step.terminated);
            assert_eq!(end.unwrap().outcome, Outcome::Timeout);
            break;
        }
        assert!(!step.truncated && !step.terminated);
    }
    assert!(periods > 50, "{periods} periods");
    // An invalid action ends the episode: advance runs no physics and reports a termination with the penalty.
    let mut run = EpisodeRun::new(&w, &task, &spec, &cfg);
    assert!(run.control(action(f64::NAN, 0.0, 0.0)).is_err());
    let step = run.advance();
    assert!(step.terminated && !step.truncated);
    assert_eq!(
        step.reward.terminal,
        -RewardWeights::default().failure_penalty
    );
    assert_eq!(step.reward.progress, 0.0);
}
