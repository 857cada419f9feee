//! Who is ranked. The main board ranks only runs comparable with each other: finished, every task of one task set,
//! on this simulator, under the default (paper's) episode rules, with ground-truth perception (`ideal`; a run under
//! another perception profile is read beside its family's ideal run, in the robustness table). Every other run is listed apart with why and its
//! coverage (finished tasks over the full set), so three lucky episodes, a run on an older simulator or one under
//! the release's rules never stand beside full runs. The service's `/` and `vb leaderboard-static` use the same
//! rule.

use contracts::{Rules, SubmissionState};
use serde::Serialize;

/// What a ranked run must have run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Reference {
    pub task_set_version: String,
    /// Tasks of the full set.
    pub tasks: u32,
    pub sim_version: String,
    pub rules: Rules,
}

impl Reference {
    /// The full set of `task_set_version` (of `tasks` tasks), on simulator `sim_version`, under the paper's rules.
    pub fn current(task_set_version: &str, tasks: u32, sim_version: &str) -> Reference {
        Reference {
            task_set_version: task_set_version.to_string(),
            tasks,
            sim_version: sim_version.to_string(),
            rules: Rules::Paper,
        }
    }

    /// One line for the board: what ranked runs ran.
    pub fn describe(&self) -> String {
        format!(
            "all {} tasks of task set {}, simulator {}, {} rules",
            self.tasks,
            self.task_set_version,
            self.sim_version,
            self.rules.as_str()
        )
    }
}

/// A run as the ranking sees it.
#[derive(Clone, Copy, Debug)]
pub struct Run<'a> {
    /// Done for a finished run (an evaluation directory is always finished).
    pub state: SubmissionState,
    /// Tasks it has (whatever their state) and tasks finished.
    pub tasks: u32,
    pub finished: u32,
    pub task_set_version: &'a str,
    pub sim_version: &'a str,
    pub rules: Rules,
    pub perception: &'a contracts::PerceptionId,
}

/// Why a run is not ranked.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "why", rename_all = "snake_case")]
pub enum Unranked {
    /// Still queued or running.
    NotFinished {
        state: SubmissionState,
    },
    Cancelled,
    OtherTaskSet {
        task_set_version: String,
    },
    OtherSimulator {
        sim_version: String,
    },
    OtherRules {
        rules: Rules,
    },
    /// Ran under a perception profile other than ground truth.
    OtherPerception {
        perception: contracts::PerceptionId,
    },
    /// Ran (or finished) fewer tasks than the full set.
    Partial {
        finished: u32,
        tasks: u32,
    },
}

impl std::fmt::Display for Unranked {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Unranked::NotFinished { state } => write!(f, "{state}"),
            Unranked::Cancelled => write!(f, "cancelled"),
            Unranked::OtherTaskSet { task_set_version } => {
                write!(f, "other task set ({task_set_version})")
            }
            Unranked::OtherSimulator { sim_version } => {
                write!(f, "other simulator ({sim_version})")
            }
            Unranked::OtherRules { rules } => write!(f, "{} rules", rules.as_str()),
            Unranked::OtherPerception { perception } => write!(f, "perception {perception}"),
            Unranked::Partial { finished, tasks } => {
                write!(f, "partial: {finished} of {tasks} tasks")
            }
        }
    }
}

impl Run<'_> {
    /// `None` when the run is ranked, else the first reason it is not.
    pub fn unranked(&self, r: &Reference) -> Option<Unranked> {
        Some(match self.state {
            SubmissionState::Done => {
                if self.task_set_version != r.task_set_version {
                    Unranked::OtherTaskSet {
                        task_set_version: self.task_set_version.to_string(),
                    }
                } else if self.sim_version != r.sim_version {
                    Unranked::OtherSimulator {
                        sim_version: self.sim_version.to_string(),
                    }
                } else if self.rules != r.rules {
                    Unranked::OtherRules { rules: self.rules }
                } else if !self.perception.is_ideal() {
                    Unranked::OtherPerception {
                        perception: self.perception.clone(),
                    }
                } else if self.tasks != r.tasks || self.finished != r.tasks {
                    Unranked::Partial {
                        finished: self.finished,
                        tasks: r.tasks,
                    }
                } else {
                    return None;
                }
            }
            SubmissionState::Cancelled => Unranked::Cancelled,
            state @ (SubmissionState::Queued | SubmissionState::Running) => {
                Unranked::NotFinished { state }
            }
        })
    }

    /// Finished tasks over the full set (0 to 1; 0 for a run on another task set, whose tasks are not the set's).
    pub fn coverage(&self, r: &Reference) -> f64 {
        if self.task_set_version != r.task_set_version || r.tasks == 0 {
            0.0
        } else {
            (self.finished as f64 / r.tasks as f64).min(1.0)
        }
    }
}

/// `1000 / 1000 (100%)`: finished tasks, the full set and the coverage.
pub fn coverage_text(finished: u32, coverage: f64, r: &Reference) -> String {
    format!("{finished} / {} ({:.1}%)", r.tasks, 100.0 * coverage)
}

#[cfg(test)]
mod tests {
    use super::*;

    static IDEAL: std::sync::LazyLock<contracts::PerceptionId> =
        std::sync::LazyLock::new(contracts::PerceptionId::ideal);

    fn run(state: SubmissionState, finished: u32) -> Run<'static> {
        Run {
            perception: &IDEAL,
            state,
            tasks: 1000,
            finished,
            task_set_version: "set",
            sim_version: "sim r1",
            rules: Rules::Paper,
        }
    }

    #[test]
    fn only_full_finished_runs_of_the_reference_are_ranked() {
        let r = Reference::current("set", 1000, "sim r1");
        assert_eq!(run(SubmissionState::Done, 1000).unranked(&r), None);
        assert_eq!(run(SubmissionState::Done, 1000).coverage(&r), 1.0);
        assert_eq!(
            run(SubmissionState::Running, 3).unranked(&r),
            Some(Unranked::NotFinished {
                state: SubmissionState::Running
            })
        );
        assert_eq!(
            run(SubmissionState::Cancelled, 3).unranked(&r),
            Some(Unranked::Cancelled)
        );
        assert_eq!(run(SubmissionState::Cancelled, 3).coverage(&r), 0.003);
        let few = Run {
            tasks: 330,
            ..run(SubmissionState::Done, 330)
        };
        assert_eq!(
            few.unranked(&r),
            Some(Unranked::Partial {
                finished: 330,
                tasks: 1000
            })
        );
        let old = Run {
            sim_version: "sim-core 0.1.0 r1",
            ..run(SubmissionState::Done, 1000)
        };
        assert_eq!(
            old.unranked(&r).map(|u| u.to_string()).as_deref(),
            Some("other simulator (sim-core 0.1.0 r1)")
        );
        let release = Run {
            rules: Rules::Release,
            ..run(SubmissionState::Done, 1000)
        };
        assert_eq!(
            release.unranked(&r),
            Some(Unranked::OtherRules {
                rules: Rules::Release
            })
        );
        let other_set = Run {
            task_set_version: "cf",
            ..run(SubmissionState::Done, 1000)
        };
        assert!(matches!(
            other_set.unranked(&r),
            Some(Unranked::OtherTaskSet { .. })
        ));
        assert_eq!(other_set.coverage(&r), 0.0);
        let noisy = contracts::PerceptionId::new("nominal@0123456789abcdef");
        let nominal = Run {
            perception: &noisy,
            ..run(SubmissionState::Done, 1000)
        };
        assert_eq!(
            nominal.unranked(&r).map(|u| u.to_string()).as_deref(),
            Some("perception nominal@0123456789abcdef")
        );
    }
}
