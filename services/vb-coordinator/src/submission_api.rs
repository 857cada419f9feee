//! The public `Coordinator` gRPC service (`CoordinatorApi`): submit, status, progress stream, list, cancel,
//! results and an episode's planner log, each checked against the caller's token.

use crate::*;

#[tonic::async_trait]
impl pb::coordinator_server::Coordinator for CoordinatorApi {
    async fn submit(
        &self,
        req: Request<pb::SubmitRequest>,
    ) -> Result<Response<pb::SubmitResponse>, Status> {
        let owner = self.0.user(&req).await?;
        let mut v = self.0.validate_submit(req.get_ref())?;
        for s in &mut v.subs {
            s.owner = owner.name.clone();
            s.owner_token = owner.id.clone();
        }
        let ids = self
            .0
            .store
            .create_family(&v.subs, &v.episodes, now())
            .await
            .map_err(store_status)?;
        Ok(Response::new(pb::SubmitResponse {
            submission_id: ids[0].clone(),
            episodes: v.episodes.len() as u32,
            submission_ids: ids,
        }))
    }

    async fn status(
        &self,
        req: Request<pb::StatusRequest>,
    ) -> Result<Response<pb::SubmissionStatus>, Status> {
        let token = self.0.user(&req).await?;
        self.0.owned(&token, &req.get_ref().submission_id).await?;
        Ok(Response::new(
            self.0.status_of(&req.get_ref().submission_id).await?,
        ))
    }

    async fn cancel(
        &self,
        req: Request<pb::CancelRequest>,
    ) -> Result<Response<pb::SubmissionStatus>, Status> {
        let token = self.0.user(&req).await?;
        let id = &req.get_ref().submission_id;
        self.0.owned(&token, id).await?;
        {
            let _g = self.0.lease_lock.lock().await;
            self.0.store.cancel(id, now()).await.map_err(store_status)?;
        }
        self.0.refresh_summary(id).await;
        Ok(Response::new(self.0.status_of(id).await?))
    }

    type WatchProgressStream = StatusStream;

    async fn watch_progress(
        &self,
        req: Request<pb::StatusRequest>,
    ) -> Result<Response<Self::WatchProgressStream>, Status> {
        let token = self.0.user(&req).await?;
        let id = req.into_inner().submission_id;
        // Fail now on an unknown (or another owner's) id rather than in the stream.
        self.0.owned(&token, &id).await?;
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        let me = self.0.clone();
        tokio::spawn(async move {
            loop {
                let s = me.status_of(&id).await;
                let end = matches!(&s, Ok(s) if matches!(s.state(), pb::SubmissionState::Done | pb::SubmissionState::Cancelled))
                    || s.is_err();
                if tx.send(s).await.is_err() || end {
                    break;
                }
                tokio::time::sleep(Duration::from_millis(500)).await;
            }
        });
        Ok(Response::new(Box::pin(
            tokio_stream::wrappers::ReceiverStream::new(rx),
        )))
    }

    async fn list_submissions(
        &self,
        req: Request<pb::ListRequest>,
    ) -> Result<Response<pb::SubmissionList>, Status> {
        let token = self.0.user(&req).await?;
        let subs = self
            .0
            .store
            .reader()
            .submissions()
            .await
            .map_err(store_status)?;
        let mut out = Vec::with_capacity(subs.len());
        let visible = subs
            .into_iter()
            .filter(|s| token.role == TokenRole::Admin || s.owner_token == token.id);
        for s in visible {
            out.push(self.0.status_of(&s.id).await?);
        }
        Ok(Response::new(pb::SubmissionList { submissions: out }))
    }

    async fn results(
        &self,
        req: Request<pb::StatusRequest>,
    ) -> Result<Response<pb::ResultsResponse>, Status> {
        let token = self.0.user(&req).await?;
        let id = &req.get_ref().submission_id;
        self.0.owned(&token, id).await?;
        let status = self.0.status_of(id).await?;
        let eps = self
            .0
            .store
            .reader()
            .episodes(id)
            .await
            .map_err(store_status)?;
        Ok(Response::new(pb::ResultsResponse {
            status: Some(status),
            episodes: eps
                .iter()
                .map(|e| {
                    let worlds = &self.0.cfg.catalog.worlds;
                    let terrain = worlds.get(&e.world_id).and_then(|w| w.terrain);
                    convert::result_row(e, terrain)
                })
                .collect(),
        }))
    }

    async fn episode_log(
        &self,
        req: Request<pb::EpisodeLogRequest>,
    ) -> Result<Response<pb::EpisodeLogResponse>, Status> {
        let token = self.0.user(&req).await?;
        let r = req.get_ref();
        self.0.owned(&token, &r.submission_id).await?;
        let task: contracts::TaskId = r.task_id.parse().map_err(|_| {
            Status::invalid_argument(format!("`{}` is not a task id (w001-t0)", r.task_id))
        })?;
        let d = self
            .0
            .store
            .reader()
            .episode_detail(&r.submission_id, task)
            .await
            .map_err(store_status)?;
        Ok(Response::new(pb::EpisodeLogResponse {
            planner_log: d.planner_log,
        }))
    }
}
