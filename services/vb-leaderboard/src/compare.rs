//! Pairwise comparison of two submissions on the tasks both finished, as `vb compare` compares two evaluation
//! directories: success rates, their paired difference with its 95% interval and the exact McNemar test, overall and
//! per elevation level, with notes when the two ran on different task sets, simulators or rules.

use crate::public::PublicSubmission;
use crate::{public, Leaderboard, WebError};
use contracts::ElevationLevel;
use results::compare::Comparison;
use results::EpisodeRow;
use serde::Serialize;

/// One side of a comparison.
#[derive(Clone, Debug, Serialize)]
pub struct Side {
    pub id: String,
    pub name: String,
    pub planner: String,
    pub state: contracts::SubmissionState,
    pub task_set_version: String,
    pub sim_version: String,
    pub rules: contracts::Rules,
    /// Its finished episodes.
    pub finished: usize,
}

/// A minus B on the tasks both finished.
#[derive(Clone, Debug, Serialize)]
pub struct Pairwise {
    pub a: Side,
    pub b: Side,
    pub overall: Comparison,
    /// The same per elevation level (levels with paired tasks only), in their natural order.
    pub by_level: Vec<(String, Comparison)>,
    /// What makes the pairing doubtful (different task sets, simulators or rules; unfinished runs).
    pub notes: Vec<String>,
}

fn side(s: &PublicSubmission, rows: &[EpisodeRow]) -> Side {
    Side {
        id: s.id.clone(),
        name: s.name.clone(),
        planner: crate::pages::submission::planner_label(s),
        state: s.state,
        task_set_version: s.task_set_version.clone(),
        sim_version: s.sim_version.to_string(),
        rules: rows.first().map(|r| r.rules).unwrap_or_default(),
        finished: rows.len(),
    }
}

/// Compares the finished episodes `ra` of A with `rb` of B.
pub fn pairwise(
    a: &PublicSubmission,
    ra: &[EpisodeRow],
    b: &PublicSubmission,
    rb: &[EpisodeRow],
) -> Pairwise {
    let (sa, sb) = (side(a, ra), side(b, rb));
    let mut notes: Vec<String> = results::compare::task_set_note(ra, rb)
        .into_iter()
        .collect();
    if sa.sim_version != sb.sim_version {
        notes.push(format!(
            "A ran on simulator {}, B on {}: their episodes are not the same physics",
            sa.sim_version, sb.sim_version
        ));
    }
    if sa.rules != sb.rules {
        notes.push(format!(
            "A ran under the {} rules, B under the {}",
            sa.rules.as_str(),
            sb.rules.as_str()
        ));
    }
    for s in [&sa, &sb] {
        if s.state != contracts::SubmissionState::Done {
            notes.push(format!(
                "`{}` is {}: only the tasks both have finished are paired",
                s.name, s.state
            ));
        }
    }
    let by_level = ElevationLevel::ALL
        .iter()
        .filter_map(|&level| {
            let of = |rows: &[EpisodeRow]| -> Vec<EpisodeRow> {
                rows.iter().filter(|r| r.level == level).cloned().collect()
            };
            let c = results::compare::compare(&of(ra), &of(rb));
            (c.paired_tasks > 0).then(|| (level.to_string(), c))
        })
        .collect();
    Pairwise {
        overall: results::compare::compare(ra, rb),
        by_level,
        notes,
        a: sa,
        b: sb,
    }
}

impl Leaderboard {
    /// A submission (as the public sees it) and its finished episodes as evaluation rows.
    pub(crate) async fn finished_rows(
        &self,
        id: &str,
    ) -> Result<(PublicSubmission, Vec<EpisodeRow>), WebError> {
        let sub = public::submission(&self.reader, id).await?;
        let eps = public::episodes(&self.reader, &sub).await?;
        let rows = vb_store::aggregate::rows_of(&sub.facts, &eps, self.catalog())?;
        Ok((sub, rows))
    }

    /// Submission `a` against submission `b`. Reads both submissions' episodes: O(two submissions).
    pub async fn compare(&self, a: &str, b: &str) -> Result<Pairwise, WebError> {
        let (sa, ra) = self.finished_rows(a).await?;
        let (sb, rb) = self.finished_rows(b).await?;
        Ok(pairwise(&sa, &ra, &sb, &rb))
    }
}
