//! The store's SQL names states and outcomes by their one string form: every `state` or `outcome` literal in the
//! store's and the coordinator's queries parses as an `EpisodeState`, a `SubmissionState` or a `RecordedOutcome`,
//! so a renamed or misspelt value cannot hide in a query string.

use contracts::{EpisodeState, RecordedOutcome, SubmissionState};
use std::path::Path;

/// Every `'literal'` compared with (`=`, `<>`, `IN (...)`) or assigned to a column named `column` in `sql`.
fn literals(sql: &str, column: &str) -> Vec<String> {
    let mut out = Vec::new();
    let bytes = sql.as_bytes();
    let mut at = 0;
    while let Some(i) = sql[at..].find(column) {
        let start = at + i;
        at = start + column.len();
        // A whole word: `state`, not `states` or `lease_state`.
        let before = start.checked_sub(1).map(|k| bytes[k]);
        if before.is_some_and(|b| b.is_ascii_alphanumeric() || b == b'_') {
            continue;
        }
        let rest = sql[at..].trim_start();
        let rest = if let Some(r) = rest.strip_prefix("<>").or_else(|| rest.strip_prefix('=')) {
            r.trim_start()
        } else if let Some(r) = rest.strip_prefix("IN") {
            r.trim_start()
        } else {
            continue;
        };
        let list = match rest.strip_prefix('(') {
            Some(r) => &r[..r.find(')').unwrap_or(r.len())],
            None => rest,
        };
        for item in list.split(',') {
            let item = item.trim();
            if let Some(lit) = item.strip_prefix('\'').and_then(|r| r.split('\'').next()) {
                out.push(lit.to_string());
            }
            if !rest.starts_with('(') {
                break;
            }
        }
    }
    out
}

#[test]
fn every_state_and_outcome_literal_in_the_queries_is_a_named_value() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut states = 0;
    let mut outcomes = 0;
    for dir in ["services/vb-store/src", "services/vb-coordinator/src"] {
        for entry in std::fs::read_dir(root.join(dir)).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            for lit in literals(&text, "state") {
                states += 1;
                assert!(
                    EpisodeState::parse(&lit).is_ok() || SubmissionState::parse(&lit).is_ok(),
                    "{}: state '{lit}' is no episode or submission state",
                    path.display()
                );
            }
            for lit in literals(&text, "outcome") {
                outcomes += 1;
                assert!(
                    RecordedOutcome::parse(&lit).is_ok(),
                    "{}: outcome '{lit}' is no outcome",
                    path.display()
                );
            }
        }
    }
    // The scan finds what it is for (the queries hold dozens of state literals and a few outcomes).
    assert!(
        states > 30 && outcomes >= 2,
        "{states} states, {outcomes} outcomes"
    );
    assert_eq!(
        literals(
            "x WHERE state IN ('queued', 'runing') AND e.state = 'done'",
            "state"
        ),
        ["queued", "runing", "done"]
    );
}
