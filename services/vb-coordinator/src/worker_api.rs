//! The internal `WorkerPool` gRPC service (`WorkerPoolApi`): register, lease, heartbeat and report, each checked
//! against the worker token (only a worker token: not a user's, not an admin's); throttles tokens that drop leases
//! or hand them back at a high rate.

use crate::*;
use vb_proto::v1::episode_report::Unscored;
use vb_store::ReportOutcome;

#[tonic::async_trait]
impl pb::worker_pool_server::WorkerPool for WorkerPoolApi {
    async fn register(
        &self,
        req: Request<pb::RegisterRequest>,
    ) -> Result<Response<pb::RegisterResponse>, Status> {
        let token = self.0.worker(&req).await?;
        let r = req.into_inner();
        let sim_version = &self.0.cfg.catalog.sim_version;
        if &r.sim_version != sim_version {
            return Err(Status::failed_precondition(format!(
                "worker runs `{}` but this coordinator's results need `{sim_version}`",
                r.sim_version
            )));
        }
        if r.worker_name.len() > 200 || r.slots == 0 || r.slots > 1024 {
            return Err(Status::invalid_argument(
                "worker_name too long or slots not in 1..=1024",
            ));
        }
        contracts::input::check_display_text("worker_name", &r.worker_name)
            .map_err(|e| Status::invalid_argument(e.to_string()))?;
        let id = self
            .0
            .store
            .register_worker(&r.worker_name, r.slots, &r.sim_version, &token.id, now())
            .await
            .map_err(store_status)?;
        Ok(Response::new(pb::RegisterResponse {
            worker_id: id,
            lease_s: self.0.cfg.lease_s,
            heartbeat_s: self.0.cfg.heartbeat_s,
        }))
    }

    async fn lease(
        &self,
        req: Request<pb::LeaseRequest>,
    ) -> Result<Response<pb::LeaseResponse>, Status> {
        let token = self.0.worker(&req).await?;
        let r = req.into_inner();
        let t = now();
        self.0.known_worker(&r.worker_id, &token, t).await?;
        let window = self.0.cfg.drop_window_s;
        let dropped = self
            .0
            .store
            .drops_since(&token.id, t - window)
            .await
            .map_err(store_status)?;
        throttle(dropped, self.0.cfg.max_dropped_leases, window, "dropped")?;
        // Handing leases back (or refusing them) uses no attempt, so a token that leases and gives back in a loop is
        // limited by rate.
        let handed = self
            .0
            .store
            .hand_backs_since(&token.id, t - window)
            .await
            .map_err(store_status)?;
        throttle(
            handed,
            self.0.cfg.max_handed_back_leases,
            window,
            "handed back",
        )?;
        let leases = {
            let _g = self.0.lease_lock.lock().await;
            self.0.store.expire_leases(t).await.map_err(store_status)?;
            self.0
                .store
                .lease_kinds(
                    &r.worker_id,
                    r.max.min(64),
                    self.0.cfg.lease_s,
                    vb_store::PlannerKinds {
                        exec: r.runs_exec_planners,
                        // Image planners are untrusted code too: never to a worker that refuses exec planners.
                        image: r.runs_exec_planners && r.runs_image_planners,
                    },
                    t,
                )
                .await
                .map_err(store_status)?
        };
        Ok(Response::new(pb::LeaseResponse {
            leases: leases
                .iter()
                .map(convert::lease)
                .collect::<Result<_, _>>()?,
        }))
    }

    async fn heartbeat(
        &self,
        req: Request<pb::HeartbeatRequest>,
    ) -> Result<Response<pb::HeartbeatResponse>, Status> {
        let token = self.0.worker(&req).await?;
        let r = req.into_inner();
        let t = now();
        self.0.known_worker(&r.worker_id, &token, t).await?;
        let gone = {
            let _g = self.0.lease_lock.lock().await;
            self.0
                .store
                .renew(&r.worker_id, &r.lease_ids, self.0.cfg.lease_s, t)
                .await
                .map_err(store_status)?
        };
        Ok(Response::new(pb::HeartbeatResponse {
            expired_lease_ids: gone,
        }))
    }

    async fn report_result(
        &self,
        req: Request<pb::EpisodeReport>,
    ) -> Result<Response<pb::ReportAck>, Status> {
        let token = self.0.worker(&req).await?;
        let r = req.into_inner();
        let t = now();
        self.0.known_worker(&r.worker_id, &token, t).await?;
        if let Some(unscored) = &r.unscored {
            self.0.unscored(&r, unscored, t).await?;
            return Ok(Response::new(pb::ReportAck {
                accepted: false,
                duplicate: false,
            }));
        }
        let result = convert::report(&r, MAX_LOG, MAX_TRAJECTORY)?;
        let sim_version = &self.0.cfg.catalog.sim_version;
        if &r.sim_version != sim_version {
            return Err(Status::invalid_argument(format!(
                "the result was computed by `{}`, not `{sim_version}`",
                r.sim_version
            )));
        }
        let sub = self
            .0
            .store
            .reader()
            .submission(&r.submission_id)
            .await
            .map_err(store_status)?;
        if r.task_set_version != sub.task_set_version {
            return Err(Status::invalid_argument(format!(
                "the result was computed on task set `{}`, the submission needs `{}`",
                r.task_set_version, sub.task_set_version
            )));
        }
        let outcome = {
            let _g = self.0.lease_lock.lock().await;
            self.0
                .store
                .report(&r.worker_id, &result, t)
                .await
                .map_err(store_status)?
        };
        // A submission's last result: its final aggregates are stored before the worker hears back.
        if outcome == ReportOutcome::Accepted {
            let ended = self
                .0
                .store
                .reader()
                .submission(&r.submission_id)
                .await
                .map_err(store_status)?;
            if ended.state == vb_store::SubmissionState::Done {
                self.0.refresh_summary(&r.submission_id).await;
            }
        }
        Ok(Response::new(pb::ReportAck {
            accepted: outcome == ReportOutcome::Accepted,
            duplicate: outcome == ReportOutcome::Duplicate,
        }))
    }
}

impl Coordinator {
    /// A report without a result to score: the lease goes back to the queue, kept from that worker if it cannot run
    /// the submission's planner, counted as an attempt if the worker failed it.
    async fn unscored(
        &self,
        r: &pb::EpisodeReport,
        unscored: &Unscored,
        t: f64,
    ) -> Result<(), Status> {
        let _g = self.lease_lock.lock().await;
        match unscored {
            Unscored::CannotRun(_) => {
                if self
                    .store
                    .refuse(&r.worker_id, &r.lease_id, &r.detail, t)
                    .await
                    .map_err(store_status)?
                {
                    tracing::warn!(
                        worker = %r.worker_id,
                        submission = %r.submission_id,
                        reason = %r.detail,
                        "a worker cannot run a submission; its episodes wait for another"
                    );
                }
            }
            Unscored::HandedBack(_) => {
                if self
                    .store
                    .hand_back(&r.worker_id, &r.lease_id, t)
                    .await
                    .map_err(store_status)?
                {
                    tracing::info!(
                        worker = %r.worker_id,
                        lease = %r.lease_id,
                        "a stopping worker handed an episode back"
                    );
                }
            }
            Unscored::InfrastructureFailure(_) => {
                tracing::warn!(
                    worker = %r.worker_id,
                    submission = %r.submission_id,
                    task = %r.task_id,
                    detail = %r.detail,
                    "a worker could not run an episode"
                );
                self.store
                    .release(&r.worker_id, &r.lease_id, &r.detail, t)
                    .await
                    .map_err(store_status)?;
            }
        }
        Ok(())
    }
}

/// RESOURCE_EXHAUSTED when a token's workers `did` (dropped, handed back) `n` leases in the last `window` s and the
/// limit is `limit`.
fn throttle(n: u64, limit: u64, window: f64, did: &str) -> Result<(), Status> {
    if n < limit {
        return Ok(());
    }
    Err(Status::resource_exhausted(format!(
        "throttled: this token's workers {did} {n} leases in the last {window:.0} s (limit {limit}); no new leases \
         until fewer remain in the window"
    )))
}
