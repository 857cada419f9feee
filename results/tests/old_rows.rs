//! Result files written before rows were typed still load, and a loaded row writes back the same JSON: rows of PID
//! and EH from `vb eval` (sim-core r7, task set v4, 2026-11-26, before the change), an infrastructure error as the
//! service records it, an episode cancelled when cancellation was reported as a timeout, and a row from before rows
//! carried `rules` and `terrain`.

use contracts::{EndReason, ObstacleDensity, Outcome, RecordedOutcome, Rules, TaskId};
use results::EpisodeRow;

const OLD: &str = include_str!("data/results-before-typed-rows.jsonl");

#[test]
fn rows_written_before_typed_rows_load_and_write_back_unchanged() {
    let lines: Vec<&str> = OLD.lines().collect();
    assert_eq!(lines.len(), 9);
    let mut rows = Vec::new();
    for line in &lines {
        let row: EpisodeRow = serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"));
        let mut original: serde_json::Value = serde_json::from_str(line).unwrap();
        let written = serde_json::to_value(&row).unwrap();
        // The oldest rows lack `rules` and `terrain`: they read as the paper's rules and no terrain group.
        let obj = original.as_object_mut().unwrap();
        obj.entry("rules").or_insert("paper".into());
        obj.entry("terrain").or_insert(serde_json::Value::Null);
        assert_eq!(written, original, "{line}");
        rows.push(row);
    }
    assert_eq!(rows[0].task_id, TaskId::new(1, 0));
    assert!(rows[0].is_success() && rows[0].reason == EndReason::Success);
    assert_eq!(rows[0].density, ObstacleDensity::Sparse);
    assert!(rows
        .iter()
        .any(|r| r.outcome == RecordedOutcome::Episode(Outcome::Rollover)));
    let err = &rows[6];
    assert_eq!(err.outcome, RecordedOutcome::InfrastructureError);
    assert_eq!(err.reason, EndReason::Infrastructure);
    // Before `Outcome::Cancelled`, a cancelled episode was a timeout with reason `cancelled`: it still reads so.
    let cancelled = &rows[7];
    assert_eq!(
        cancelled.outcome,
        RecordedOutcome::Episode(Outcome::Timeout)
    );
    assert_eq!(cancelled.reason, EndReason::Cancelled);
    assert_eq!((rows[8].rules, rows[8].terrain), (Rules::Paper, None));
}

#[test]
fn a_row_with_an_unknown_factor_or_outcome_is_a_clear_error() {
    let line = OLD.lines().next().unwrap();
    for (from, to, what) in [
        (
            "\"level\":\"low\"",
            "\"level\":\"lowish\"",
            "unknown elevation level `lowish`",
        ),
        (
            "\"outcome\":\"success\"",
            "\"outcome\":\"won\"",
            "unknown outcome `won`",
        ),
        (
            "\"task_id\":\"w001-t0\"",
            "\"task_id\":\"w1-t0\"",
            "`w1-t0` is not a task id",
        ),
    ] {
        let bad = line.replacen(from, to, 1);
        assert_ne!(bad, line);
        let e = serde_json::from_str::<EpisodeRow>(&bad)
            .unwrap_err()
            .to_string();
        assert!(e.contains(what), "{e}");
    }
}
