//! Robustness to perception (issue 61): the submissions of one family (one request evaluated under several
//! perception profiles) side by side: each profile's success, its paired drop from the family's `ideal` run on the
//! tasks both finished (with its 95% interval and the exact McNemar test, as `vb compare` reports it), and its
//! success per elevation level, semantics and obstacle density.

use crate::{Leaderboard, SubmissionEntry, WebError};
use contracts::{ElevationLevel, ObstacleDensity, PerceptionId, SemanticsKind, SubmissionState};
use results::compare::Comparison;
use serde::Serialize;
use std::collections::BTreeMap;

/// What a family's table was computed from: each member's id, state and finished episodes.
pub type FamilyKey = Vec<(String, SubmissionState, u32)>;

/// One profile of a family.
#[derive(Clone, Debug, Serialize)]
pub struct ProfileRun {
    /// The submission that ran it.
    pub id: String,
    pub perception: PerceptionId,
    pub state: SubmissionState,
    pub finished: u32,
    pub success_rate: f64,
    /// This profile minus `ideal` on the tasks both finished (`None` for the ideal run, or when the family has
    /// none).
    pub drop_from_ideal: Option<Comparison>,
    pub by_level: BTreeMap<ElevationLevel, f64>,
    pub by_semantics: BTreeMap<SemanticsKind, f64>,
    pub by_density: BTreeMap<ObstacleDensity, f64>,
}

/// A family of submissions, one per perception profile, in submission order.
#[derive(Clone, Debug, Serialize)]
pub struct Robustness {
    /// The family's id (its first submission's).
    pub family: String,
    pub name: String,
    pub profiles: Vec<ProfileRun>,
}

fn rates<K: Ord + Copy>(m: &BTreeMap<K, results::summary::Aggregate>) -> BTreeMap<K, f64> {
    m.iter().map(|(k, a)| (*k, a.success_rate)).collect()
}

/// Every family of more than one submission among `entries`, in the order of their first submissions.
pub fn families(entries: &[SubmissionEntry]) -> Vec<String> {
    let mut first: BTreeMap<&str, i64> = BTreeMap::new();
    let mut count: BTreeMap<&str, usize> = BTreeMap::new();
    for e in entries {
        let f = e.submission.family.as_str();
        let seq = first.entry(f).or_insert(e.submission.seq);
        *seq = (*seq).min(e.submission.seq);
        *count.entry(f).or_default() += 1;
    }
    let mut out: Vec<(&str, i64)> = first
        .into_iter()
        .filter(|(f, _)| count.get(f).is_some_and(|&n| n > 1))
        .collect();
    out.sort_by_key(|&(_, seq)| seq);
    out.into_iter().map(|(f, _)| f.to_string()).collect()
}

impl Leaderboard {
    /// Family `family` from the ranking's `entries` (`None` when none of them is of it; a submission made alone is
    /// a family of one). Reads the episodes of its members: O(the family's submissions).
    pub async fn robustness(
        &self,
        family: &str,
        entries: &[SubmissionEntry],
    ) -> Result<Option<Robustness>, WebError> {
        let mut members: Vec<&SubmissionEntry> = entries
            .iter()
            .filter(|e| e.submission.family == family)
            .collect();
        if members.is_empty() {
            return Ok(None);
        }
        members.sort_by_key(|e| e.submission.seq);
        let ideal = match members.iter().find(|e| e.submission.perception.is_ideal()) {
            Some(e) => Some(self.finished_rows(&e.submission.id).await?.1),
            None => None,
        };
        let mut profiles = Vec::with_capacity(members.len());
        for e in &members {
            let s = &e.submission;
            let drop_from_ideal = match (&ideal, s.perception.is_ideal()) {
                (Some(ideal), false) => {
                    let rows = self.finished_rows(&s.id).await?.1;
                    Some(results::compare::compare(&rows, ideal))
                }
                _ => None,
            };
            profiles.push(ProfileRun {
                id: s.id.clone(),
                perception: s.perception.clone(),
                state: s.state,
                finished: e.progress.finished,
                success_rate: e.summary.overall.success_rate,
                drop_from_ideal,
                by_level: rates(&e.summary.by_level),
                by_semantics: rates(&e.summary.by_semantics),
                by_density: rates(&e.summary.by_density),
            });
        }
        Ok(Some(Robustness {
            family: family.to_string(),
            name: members[0].submission.name.clone(),
            profiles,
        }))
    }

    /// Every family of the ranking's `entries` ([`families`]). A family's table is computed again only when one
    /// of its members changed (its state or finished count), so the board's readings stay one row per submission.
    pub async fn all_robustness(
        &self,
        entries: &[SubmissionEntry],
    ) -> Result<Vec<Robustness>, WebError> {
        let mut out = Vec::new();
        for f in families(entries) {
            let key: FamilyKey = entries
                .iter()
                .filter(|e| e.submission.family == f)
                .map(|e| {
                    (
                        e.submission.id.clone(),
                        e.submission.state,
                        e.progress.finished,
                    )
                })
                .collect();
            let cached = self
                .families
                .lock()
                .ok()
                .and_then(|m| m.get(&f).filter(|(k, _)| *k == key).map(|(_, r)| r.clone()));
            let table = match cached {
                Some(r) => Some(r),
                None => self.robustness(&f, entries).await?,
            };
            if let Some(r) = table {
                if let Ok(mut m) = self.families.lock() {
                    m.insert(f.clone(), (key, r.clone()));
                }
                out.push(r);
            }
        }
        Ok(out)
    }
}
