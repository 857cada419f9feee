//! End-to-end tests of the evaluation service over real gRPC and a real database, with every part a separate
//! process: `vb coordinator`, two `vb worker`s, `vb leaderboard`, and the example planner (started by the workers for
//! `exec` submissions, or by the test as an endpoint).
//!
//! One test binary, split by what is tested: `resilience` (workers that die, stop or run misbehaving planners),
//! `requests` (bad input from users and workers, ownership, cancel, endpoints; the worker API in `worker_api`)
//! and `stores` (PostgreSQL; workers that lease and drop).

mod requests;
mod resilience;
mod stores;
mod worker_api;

use integration::*;
use vb_proto::v1 as pb;

fn exec_request(name: &str, tasks: &[&str], args: &[&str], deadline: f64) -> pb::SubmitRequest {
    let mut argv = vec![example_planner().display().to_string()];
    argv.extend(args.iter().map(|s| s.to_string()));
    pb::SubmitRequest {
        name: name.into(),
        planner: Some(pb::PlannerRef {
            kind: Some(pb::planner_ref::Kind::Exec(pb::ExecPlanner { argv })),
        }),
        task_ids: tasks.iter().map(|s| s.to_string()).collect(),
        step_deadline_s: deadline,
        ..Default::default()
    }
}

/// The step deadline of the planners that are not meant to time out: generous, so that a loaded 2-core machine (a
/// debug build, several workers and planner processes at once) cannot end a good episode as a planner failure.
const STEP_S: f64 = 5.0;

fn done(s: &pb::SubmissionStatus) -> bool {
    matches!(
        s.state(),
        pb::SubmissionState::Done | pb::SubmissionState::Cancelled
    )
}
