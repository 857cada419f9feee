//! The worker API: a worker token on every call, the simulator version checked, and no result taken that no lease
//! covers.

use crate::exec_request;
use integration::*;
use vb_proto::v1 as pb;

/// Registers, leases and reports as an intruder would; returns the submission it tried to forge a result for
/// (still queued: no worker runs in this part).
pub(crate) async fn refuses_what_no_leased_worker_may_do(
    url: &str,
    db: &str,
    token: &str,
    c: &mut vb_submit::Client,
) -> anyhow::Result<pb::SubmitResponse> {
    // The worker API wants a worker token on every call; a user's token is not one.
    let worker_token = create_token_with_role(db, "rogue-test", "worker");
    fn authed<T>(msg: T, token: &str) -> tonic::Request<T> {
        let mut r = tonic::Request::new(msg);
        r.metadata_mut()
            .insert("authorization", format!("Bearer {token}").parse().unwrap());
        r
    }
    let register = |name: &str, sim: &str| pb::RegisterRequest {
        worker_name: name.into(),
        slots: 1,
        sim_version: sim.into(),
    };
    let mut w = pb::worker_pool_client::WorkerPoolClient::connect(url.to_string()).await?;
    let e = w
        .register(register("anonymous", vb_worker::SIM_VERSION))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::Unauthenticated, "{e}");
    let e = w
        .register(authed(register("user", vb_worker::SIM_VERSION), token))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::PermissionDenied, "{e}");
    // ... it refuses a worker with another simulator version, and reports from workers it does not know under
    // this token.
    let e = w
        .register(authed(register("old", "sim-core 0.0.1"), &worker_token))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::FailedPrecondition, "{e}");
    let e = w
        .report_result(authed(
            pb::EpisodeReport {
                worker_id: "wk-nope".into(),
                outcome: pb::Outcome::Success.into(),
                ..Default::default()
            },
            &worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e}");
    let reg = w
        .register(authed(register("w", vb_worker::SIM_VERSION), &worker_token))
        .await?
        .into_inner();
    let other_worker_token = create_token_with_role(db, "other", "worker");
    let e = w
        .lease(authed(
            pb::LeaseRequest {
                worker_id: reg.worker_id.clone(),
                max: 1,
                runs_exec_planners: true,
                runs_image_planners: false,
            },
            &other_worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(
        e.code(),
        tonic::Code::NotFound,
        "another token cannot use this worker: {e}"
    );
    // An outcome number the protocol does not define, or none (UNSPECIFIED), is refused.
    for (outcome, says) in [(99, "unknown outcome number 99"), (0, "no outcome given")] {
        let e = w
            .report_result(authed(
                pb::EpisodeReport {
                    worker_id: reg.worker_id.clone(),
                    outcome,
                    reason: pb::EndReason::Success.into(),
                    ..Default::default()
                },
                &worker_token,
            ))
            .await
            .unwrap_err();
        assert!(
            e.code() == tonic::Code::InvalidArgument && e.message().contains(says),
            "{e}"
        );
    }
    // A forged success for an episode this worker never leased is not taken, nor one with a bogus simulator
    // version or task set.
    let victim = vb_submit::submit(c, exec_request("victim", &["9"], &[], 1.0)).await?;
    let forged = |sim: &str, set: &str| pb::EpisodeReport {
        worker_id: reg.worker_id.clone(),
        lease_id: "ls-forged".into(),
        submission_id: victim.submission_id.clone(),
        task_id: "w009-t0".into(),
        outcome: pb::Outcome::Success.into(),
        reason: pb::EndReason::Success.into(),
        sim_version: sim.into(),
        task_set_version: set.into(),
        metrics: Some((&sim_core::episode::EpisodeMetrics::default()).into()),
        ..Default::default()
    };
    let set_version = tasks::TaskSet::committed()?.version().to_string();
    let ack = w
        .report_result(authed(
            forged(vb_worker::SIM_VERSION, &set_version),
            &worker_token,
        ))
        .await?
        .into_inner();
    assert!(
        !ack.accepted && !ack.duplicate,
        "a report without the lease is rejected"
    );
    let e = w
        .report_result(authed(
            forged("sim-core 9.9.9", &set_version),
            &worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
    let e = w
        .report_result(authed(
            forged(vb_worker::SIM_VERSION, "0000000000000000"),
            &worker_token,
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
    let results = vb_submit::results(c, &victim.submission_id).await?;
    assert!(
        results
            .episodes
            .iter()
            .all(|e| e.outcome() != pb::Outcome::Success),
        "no forged result was stored (no worker has run the submission yet)"
    );
    Ok(victim)
}
