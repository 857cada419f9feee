//! Failure windows (paper, section III-G 3): the last 10 s of simulated time before a rollover or a stuck, labelled
//! by the episode's outcome under the benchmark's rules: [`Outcome::Rollover`] (more than 30 degrees of roll at the
//! end of a failed trial, or overturned) or [`Outcome::Stuck`] (moved less than 1 m, scaled, in the last 10 s).
//! An episode shorter than the window gives all its frames and is marked `short`. Episodes that diverged
//! numerically (`numerical_failure`, counted as rollovers by the benchmark) are simulator failures, not the
//! vehicle's, and give no window.

use crate::record::{DatasetKind, FailureClass, FailureWindow, Frames, RecordedEpisode};
use contracts::{EndReason, Outcome};

/// Length of a failure window, simulated s (the stuck rule's window, at any scale).
pub const WINDOW_S: f64 = 10.0;

/// Frames in a window at `period` s a frame (192 at the benchmark's 20 Hz on a 4 ms physics step, whose control
/// period is 13 steps, 52 ms).
pub fn window_frames(period: f64) -> usize {
    (WINDOW_S / period).round().max(1.0) as usize
}

/// The `source` of the windows of a run: `random`, `expert:<planner>` or `eval:<planner>`.
pub fn source_name(kind: DatasetKind, planner: &str) -> String {
    match kind {
        DatasetKind::Random => "random".to_string(),
        DatasetKind::Expert => format!("expert:{planner}"),
        DatasetKind::Failures => format!("eval:{planner}"),
    }
}

/// A class's name, as in the dataset files (`rollover`, `stuck`).
pub fn class_name(class: FailureClass) -> &'static str {
    match class {
        FailureClass::Rollover => "rollover",
        FailureClass::Stuck => "stuck",
    }
}

/// The failure class of an episode's end, if it is one.
pub fn class_of(outcome: Outcome, reason: EndReason) -> Option<FailureClass> {
    match (outcome, reason) {
        (_, EndReason::NumericalFailure) => None,
        (Outcome::Rollover, _) => Some(FailureClass::Rollover),
        (Outcome::Stuck, _) => Some(FailureClass::Stuck),
        _ => None,
    }
}

/// The last `n` frames of `frames` (all of them when there are fewer).
pub fn tail(frames: &Frames, n: usize) -> Frames {
    let len = frames.len();
    let from = len.saturating_sub(n);
    let per = |v: usize| v.checked_div(len).unwrap_or(0);
    let wheels = per(frames.wheels.len());
    let cut = |v: &Vec<f32>| v[from * per(v.len())..].to_vec();
    Frames {
        state: frames.state[from..].to_vec(),
        goal: frames.goal[from..].to_vec(),
        wheels: frames.wheels[from * wheels..].to_vec(),
        action: frames.action[from..].to_vec(),
        reward_terms: frames.reward_terms[from..].to_vec(),
        terminated: frames.terminated[from..].to_vec(),
        truncated: frames.truncated[from..].to_vec(),
        elevation: frames.elevation.as_ref().map(cut),
        semantics: frames.semantics.as_ref().map(cut),
    }
}

/// The failure window of a recorded episode (`period` s a frame), from run `source`'s episode `source_episode`;
/// `None` when the episode did not end in a rollover or a stuck.
pub fn failure_window(
    rec: &RecordedEpisode,
    period: f64,
    source: &str,
    source_episode: u64,
) -> Option<RecordedEpisode> {
    let class = class_of(rec.meta.outcome, rec.meta.reason)?;
    let n = window_frames(period);
    let len = rec.frames.len();
    let from = len.saturating_sub(n);
    // The window's frames are the source's last ones, so its final observation (`meta.final_state`, `final_goal`)
    // is the source's, kept by the clone.
    let mut meta = rec.meta.clone();
    meta.kind = DatasetKind::Failures;
    meta.failure = Some(FailureWindow {
        class,
        source: source.to_string(),
        source_episode,
        start_time: from as f64 * period,
        short: len < n,
    });
    Some(RecordedEpisode {
        meta,
        frames: tail(&rec.frames, n),
    })
}
