//! Conversions between protobuf messages and the store's types (protobuf stays at the service edge). The
//! vocabulary's enums and the metrics convert through `vb_proto::convert`; the store keeps their string forms and
//! the metrics as JSON.

use contracts::{EndReason, EpisodeMetrics, RecordedOutcome};
use std::io::Read;
use tonic::Status;
use vb_proto::v1 as pb;
use vb_proto::ProtoEnum;
use vb_store::{EpisodeRecord, EpisodeResultIn, Lease, PlannerSpec, Progress, Submission};

/// The planner reference a submission was made with, as the worker gets it (the store has already read its spec
/// strictly: a corrupt stored argv never reaches here).
pub fn planner_ref(spec: &PlannerSpec) -> pb::PlannerRef {
    use pb::planner_ref::Kind;
    let kind = match spec {
        PlannerSpec::Builtin(name) => Kind::Builtin(name.to_string()),
        PlannerSpec::Endpoint(url) => Kind::Endpoint(url.clone()),
        PlannerSpec::Image(image) => Kind::Image(image.clone()),
        PlannerSpec::Exec(argv) => Kind::Exec(pb::ExecPlanner { argv: argv.clone() }),
    };
    pb::PlannerRef { kind: Some(kind) }
}

/// A lease as the worker gets it.
pub fn lease(l: &Lease) -> Result<pb::EpisodeLease, Status> {
    let s = &l.submission;
    Ok(pb::EpisodeLease {
        lease_id: l.lease_id.clone(),
        submission_id: s.id.clone(),
        task_id: l.task_id.to_string(),
        planner: Some(planner_ref(&s.planner)),
        vehicle: s.vehicle.to_string(),
        scale: s.scale,
        seed: s.seed,
        step_deadline_s: s.step_deadline_s,
        task_set_version: s.task_set_version.clone(),
        perception: s.perception.id.to_string(),
        perception_params: s.perception.params.clone(),
    })
}

/// A submission's status; `throughput_per_s`: the service's recent episodes per second (`None`: not known yet, so
/// no ETA).
pub fn status(s: &Submission, p: &Progress, throughput_per_s: Option<f64>) -> pb::SubmissionStatus {
    let active = s.state.is_active();
    let throughput_per_s = throughput_per_s.unwrap_or(0.0);
    let eta_known = active && throughput_per_s > 0.0;
    pb::SubmissionStatus {
        submission_id: s.id.clone(),
        state: s.state.wire(),
        total: p.total,
        finished: p.finished,
        running: p.running,
        not_run: p.not_run,
        queue_position: p.queue_position,
        eta_s: if eta_known {
            p.episodes_ahead as f64 / throughput_per_s
        } else if active {
            -1.0
        } else {
            0.0
        },
        success_rate: if p.finished > 0 {
            p.successes as f64 / p.finished as f64
        } else {
            0.0
        },
        name: s.name.clone(),
        planner: s.planner.to_string(),
        planner_identity: s.planner_identity.clone(),
        task_set_version: s.task_set_version.clone(),
        sim_version: s.sim_version.to_string(),
        vehicle: s.vehicle.to_string(),
        queued: p.queued,
        eta_known,
        scale: s.scale,
        seed: s.seed,
        rules: vb_store::SERVICE_RULES.wire(),
        perception: s.perception.id.to_string(),
        family: s.family.clone(),
    }
}

/// An episode as the results API returns it; `terrain`: its world's terrain group in the task set (a corrupt
/// stored value already failed the store's read).
pub fn result_row(e: &EpisodeRecord, terrain: Option<u32>) -> pb::EpisodeResultRow {
    pb::EpisodeResultRow {
        task_id: e.task_id.to_string(),
        world_id: e.world_id,
        task_index: e.task_index,
        level: e.level.wire(),
        semantics: e.semantics.wire(),
        density: e.density.wire(),
        state: e.state.wire(),
        outcome: e.outcome.map(ProtoEnum::wire),
        reason: e.reason.map(ProtoEnum::wire),
        detail: e.detail.clone().unwrap_or_default(),
        metrics: e.metrics.clone().map(pb::Metrics::from),
        wall_time_s: e.wall_time_s.unwrap_or(0.0),
        attempts: e.attempts.max(0) as u32,
        planner_identity: e.planner_identity.clone().unwrap_or_default(),
        sim_version: e
            .sim_version
            .as_ref()
            .map(|v| v.to_string())
            .unwrap_or_default(),
        terrain,
    }
}

fn truncate(s: &str, max: usize) -> String {
    if s.len() <= max {
        return s.to_string();
    }
    let mut cut = max;
    while !s.is_char_boundary(cut) {
        cut -= 1;
    }
    format!("{}\n[... log truncated at {max} bytes]", &s[..cut])
}

/// Validates a worker's report (an unspecified or unknown outcome or reason is refused) and checks its
/// gzip-compressed trajectory.
pub fn report(
    r: &pb::EpisodeReport,
    max_log: usize,
    max_trajectory: usize,
) -> Result<EpisodeResultIn, Status> {
    let outcome = RecordedOutcome::from_wire(r.outcome)?;
    let reason = EndReason::from_wire(r.reason)?;
    // Checked (size, codec) but stored as the worker compressed it.
    let mut trajectory = String::new();
    if !r.trajectory.is_empty() {
        flate2_decode(&r.trajectory, max_trajectory, &mut trajectory)?;
        contracts::trajectory::from_csv(&trajectory)
            .map_err(|e| Status::invalid_argument(e.to_string()))?;
    }
    let task_id = r
        .task_id
        .parse()
        .map_err(|e: contracts::TaskIdError| Status::invalid_argument(e.to_string()))?;
    Ok(EpisodeResultIn {
        lease_id: r.lease_id.clone(),
        submission_id: r.submission_id.clone(),
        task_id,
        outcome,
        reason,
        detail: truncate(&r.detail, 16 << 10),
        metrics: r.metrics.map(EpisodeMetrics::from),
        trajectory_csv: String::new(),
        trajectory_gz: (!r.trajectory.is_empty()).then(|| r.trajectory.clone()),
        planner_log: truncate(&r.planner_log, max_log),
        sim_version: r.sim_version.as_str().into(),
        planner_identity: r.planner_identity.clone(),
        wall_time_s: r.wall_time_s,
    })
}

fn flate2_decode(bytes: &[u8], max: usize, out: &mut String) -> Result<(), Status> {
    let dec = flate2::read::GzDecoder::new(bytes);
    let mut limited = dec.take(max as u64 + 1);
    limited.read_to_string(out).map_err(|e| {
        Status::invalid_argument(format!("trajectory is not gzip-compressed UTF-8 CSV: {e}"))
    })?;
    if out.len() > max {
        return Err(Status::invalid_argument(format!(
            "trajectory is larger than {max} bytes"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use contracts::{
        ElevationLevel, EpisodeState, ObstacleDensity, Outcome, PlannerKind, SemanticsKind,
    };

    /// An exec planner's stored argv reaches the worker as it was submitted, each argument whole (the store's
    /// read refuses a spec that is not a JSON argv: `vb_store::PlannerSpec`'s test).
    #[test]
    fn a_stored_exec_planner_is_its_argv() {
        use pb::planner_ref::Kind;
        let stored =
            PlannerSpec::from_columns(PlannerKind::Exec, r#"["python3","-m","my planner"]"#)
                .unwrap();
        let Some(Kind::Exec(e)) = planner_ref(&stored).kind else {
            panic!("{stored:?}")
        };
        assert_eq!(e.argv, ["python3", "-m", "my planner"]);
        let b = planner_ref(&PlannerSpec::Builtin("pid".into()));
        assert_eq!(b.kind, Some(Kind::Builtin("pid".into())));
    }

    fn metrics() -> EpisodeMetrics {
        let mut m = EpisodeMetrics {
            time: 28.768000000002946,
            throttle_tv: 3.9066006773336635,
            final_goal_distance: 9.992706353594361,
            obstacle_contacts: 2,
            steps: 14_384,
            ..Default::default()
        };
        m.pitch.mean = -2.0042475476114894;
        m
    }

    /// A report's values are taken typed, and the results row gives back the same values, bit for bit (the store's
    /// tests check the stored text is as before).
    #[test]
    fn a_report_is_taken_typed_and_read_back_the_same() {
        let m = metrics();
        let r = pb::EpisodeReport {
            task_id: "w001-t2".into(),
            outcome: pb::Outcome::Timeout.into(),
            reason: pb::EndReason::Timeout.into(),
            metrics: Some((&m).into()),
            ..Default::default()
        };
        let stored = report(&r, 1024, 1024).unwrap();
        assert_eq!(
            (stored.outcome, stored.reason),
            (
                RecordedOutcome::Episode(Outcome::Timeout),
                EndReason::Timeout
            )
        );
        assert_eq!(format!("{:?}", stored.metrics), format!("{:?}", Some(&m)));
        let rec = EpisodeRecord {
            submission_id: "s1".into(),
            task_id: "w001-t2".parse().unwrap(),
            world_id: 1,
            task_index: 2,
            level: ElevationLevel::High,
            semantics: SemanticsKind::Mixed,
            density: ObstacleDensity::Dense,
            state: EpisodeState::Done,
            attempts: 1,
            outcome: Some(RecordedOutcome::Episode(Outcome::Timeout)),
            reason: Some(stored.reason),
            detail: None,
            metrics: stored.metrics,
            sim_version: None,
            planner_identity: None,
            wall_time_s: Some(1.5),
            finished_at: None,
        };
        let row = result_row(&rec, Some(3));
        assert_eq!(
            (row.level(), row.semantics(), row.density(), row.state()),
            (
                pb::ElevationLevel::High,
                pb::SemanticsKind::Mixed,
                pb::ObstacleDensity::Dense,
                pb::EpisodeState::Done
            )
        );
        assert_eq!(
            (row.outcome(), row.reason()),
            (pb::Outcome::Timeout, pb::EndReason::Timeout)
        );
        let back = EpisodeMetrics::from(row.metrics.unwrap());
        assert_eq!(format!("{back:?}"), format!("{m:?}"));

        // Not run yet: no outcome, reason or metrics.
        let queued = EpisodeRecord {
            state: EpisodeState::Queued,
            outcome: None,
            reason: None,
            metrics: None,
            ..rec
        };
        let row = result_row(&queued, None);
        assert_eq!((row.outcome, row.reason, row.metrics), (None, None, None));
    }

    #[test]
    fn a_report_without_an_outcome_or_reason_is_refused() {
        for (outcome, reason, says) in [
            (0, pb::EndReason::Success as i32, "no outcome given"),
            (
                99,
                pb::EndReason::Success as i32,
                "unknown outcome number 99",
            ),
            (pb::Outcome::Success as i32, 0, "no end reason given"),
        ] {
            let r = pb::EpisodeReport {
                outcome,
                reason,
                ..Default::default()
            };
            let e = report(&r, 1024, 1024).unwrap_err();
            assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
            assert!(e.message().contains(says), "{e}");
        }
        // A task id that is not one (`TaskId` parses it at the edge).
        let r = pb::EpisodeReport {
            task_id: "w1-x".into(),
            outcome: pb::Outcome::Success as i32,
            reason: pb::EndReason::Success as i32,
            ..Default::default()
        };
        let e = report(&r, 1024, 1024).unwrap_err();
        assert_eq!(e.code(), tonic::Code::InvalidArgument, "{e}");
        assert!(e.message().contains("not a task id"), "{e}");
    }
}
