//! The coordinator: turns submissions into one queued episode per task, leases episodes to workers, takes their
//! reports, and answers status, progress, cancel and results. It is the only writer of the store.
//!
//! Restart safety: every piece of scheduling state (queue, leases with their expiry, results) lives in the store, so
//! a restarted coordinator continues where it stopped; workers retry their calls until it is back.

// tonic::Status is large (176 bytes) and is the error type of every gRPC handler; boxing it everywhere buys nothing.
#![allow(clippy::result_large_err)]

mod convert;
mod submission_api;
mod validate;
mod worker_api;

use contracts::Catalog;
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};
use tokio::sync::Mutex;
use tonic::{Request, Response, Status};
use vb_proto::v1 as pb;
use vb_store::{NewEpisode, NewSubmission, Store, StoreError, Submission, Token, TokenRole};

pub use convert::planner_ref;

/// Largest gRPC message the coordinator accepts (a report carries a trajectory and a log).
pub const MAX_MESSAGE_BYTES: usize = 8 << 20;

/// Limits on what a submission may contain.
const MAX_NAME: usize = 100;
const MAX_ARGV: usize = 64;
const MAX_ARG_LEN: usize = 4096;
const MAX_SPEC_LEN: usize = 2048;
const MAX_LOG: usize = 256 << 10;
const MAX_TRAJECTORY: usize = 16 << 20;

#[derive(Clone, Debug)]
pub struct CoordinatorConfig {
    /// The benchmark served: the task set, the simulator results must come from, vehicles and built-in planners
    /// (the binary builds it with `eval::catalog`).
    pub catalog: Arc<Catalog>,
    /// How long a lease lasts without a heartbeat, s.
    pub lease_s: f64,
    /// How often workers should heartbeat, s.
    pub heartbeat_s: f64,
    /// Whether `exec` and `image` planners are accepted (workers then start user code in their own processes).
    pub allow_exec: bool,
    /// A worker token whose workers dropped this many leases (expired or released without a result) within
    /// `drop_window_s` gets no new leases until the window has passed.
    pub max_dropped_leases: u64,
    pub drop_window_s: f64,
    /// A worker token whose workers gave back this many leases unrun (handed back when stopping, or refused) within
    /// `drop_window_s` gets no new leases until fewer remain in the window: its own budget, larger than the drop
    /// budget, since a stopping worker hands back all it holds at once (neither uses an attempt of the episode).
    pub max_handed_back_leases: u64,
}

impl CoordinatorConfig {
    pub fn new(catalog: Arc<Catalog>) -> Self {
        CoordinatorConfig {
            catalog,
            lease_s: 30.0,
            heartbeat_s: 5.0,
            allow_exec: true,
            max_dropped_leases: 32,
            drop_window_s: 600.0,
            max_handed_back_leases: 256,
        }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CoordinatorError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("TLS: {0}")]
    Tls(String),
}

/// Seconds since the Unix epoch (the coordinator's clock; only services use wall time).
pub fn now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map(|d| d.as_secs_f64())
        .unwrap_or(0.0)
}

/// Shared state of both gRPC services.
pub struct Coordinator {
    store: Store,
    cfg: CoordinatorConfig,
    /// Serialises leasing so two workers never get the same episode (portable across SQLite and PostgreSQL).
    lease_lock: Mutex<()>,
}

fn store_status(e: StoreError) -> Status {
    vb_proto::status(&e)
}

impl Coordinator {
    pub fn new(store: Store, cfg: CoordinatorConfig) -> Result<Arc<Coordinator>, CoordinatorError> {
        Ok(Arc::new(Coordinator {
            store,
            cfg,
            lease_lock: Mutex::new(()),
        }))
    }

    pub fn store(&self) -> &Store {
        &self.store
    }

    /// The public submission API.
    pub fn coordinator_service(
        self: &Arc<Self>,
    ) -> pb::coordinator_server::CoordinatorServer<CoordinatorApi> {
        pb::coordinator_server::CoordinatorServer::new(CoordinatorApi(self.clone()))
            .max_decoding_message_size(MAX_MESSAGE_BYTES)
    }

    /// The internal worker API.
    pub fn worker_pool_service(
        self: &Arc<Self>,
    ) -> pb::worker_pool_server::WorkerPoolServer<WorkerPoolApi> {
        pb::worker_pool_server::WorkerPoolServer::new(WorkerPoolApi(self.clone()))
            .max_decoding_message_size(MAX_MESSAGE_BYTES)
    }

    /// Returns expired leases to the queue every `lease_s / 2` seconds, forever (spawn it).
    pub async fn run_lease_sweeper(self: Arc<Self>) {
        let period = Duration::from_secs_f64((self.cfg.lease_s / 2.0).max(0.2));
        loop {
            tokio::time::sleep(period).await;
            let _guard = self.lease_lock.lock().await;
            if let Err(e) = self.store.expire_leases(now()).await {
                tracing::error!(error = %e, "lease sweep failed");
            }
        }
    }

    /// Keeps each submission's stored aggregates current, forever (spawn it): every second it refreshes those that
    /// cover fewer finished episodes than the submission has (results arrived, leases expired into recorded
    /// failures, or an older store without them). O(one submission) per refresh.
    pub async fn run_summary_keeper(self: Arc<Self>) {
        loop {
            match self.store.stale_summaries().await {
                Ok(ids) => {
                    for id in ids {
                        self.refresh_summary(&id).await;
                    }
                }
                Err(e) => tracing::error!(error = %e, "summary sweep failed"),
            }
            tokio::time::sleep(Duration::from_secs(1)).await;
        }
    }

    /// Stores a submission's aggregates now (a failure is logged: the keeper tries again).
    async fn refresh_summary(&self, id: &str) {
        if let Err(e) = self
            .store
            .refresh_summary(id, Some(&self.cfg.catalog), now())
            .await
        {
            tracing::error!(submission = %id, error = %e, "summarising failed");
        }
    }

    /// The token a request carries (`authorization: Bearer <token>`).
    async fn authenticate<T>(&self, req: &Request<T>) -> Result<Token, Status> {
        let header = req
            .metadata()
            .get("authorization")
            .ok_or_else(|| Status::unauthenticated("missing token: send `authorization: Bearer <token>` (vb-submit --token or VB_TOKEN; create one with `vb admin token create`)"))?;
        let value = header
            .to_str()
            .map_err(|_| Status::unauthenticated("authorization header is not text"))?;
        let token = value
            .strip_prefix("Bearer ")
            .ok_or_else(|| {
                Status::unauthenticated("authorization header must be `Bearer <token>`")
            })?
            .trim();
        self.store
            .check_token(token)
            .await
            .map_err(store_status)?
            .ok_or_else(|| Status::unauthenticated("unknown or revoked token"))
    }

    /// A user's or admin's token (the submission API).
    async fn user<T>(&self, req: &Request<T>) -> Result<Token, Status> {
        let t = self.authenticate(req).await?;
        if t.role == TokenRole::Worker {
            return Err(Status::permission_denied(
                "a worker token cannot use the submission API",
            ));
        }
        Ok(t)
    }

    /// A worker's token (the worker API): roles are kept apart, so neither a user's nor an admin's token works here.
    async fn worker<T>(&self, req: &Request<T>) -> Result<Token, Status> {
        let t = self.authenticate(req).await?;
        if t.role != TokenRole::Worker {
            return Err(Status::permission_denied(format!(
                "the worker API needs a worker token (`vb admin token create --role worker`), not a{} {} token",
                if t.role == TokenRole::Admin { "n" } else { "" },
                t.role.as_str()
            )));
        }
        Ok(t)
    }

    /// Submission `id` if `token` may see it (its owner, or an admin); else the same answer as for an unknown id.
    async fn owned(&self, token: &Token, id: &str) -> Result<Submission, Status> {
        check_id(id)?;
        let sub = self
            .store
            .reader()
            .submission(id)
            .await
            .map_err(store_status)?;
        if token.role == TokenRole::Admin
            || (!sub.owner_token.is_empty() && sub.owner_token == token.id)
        {
            Ok(sub)
        } else {
            Err(Status::not_found(format!("no submission `{id}`")))
        }
    }

    /// Marks worker `id` seen, if it is registered under `token`.
    async fn known_worker(&self, id: &str, token: &Token, t: f64) -> Result<(), Status> {
        if self
            .store
            .touch_worker(id, &token.id, t)
            .await
            .map_err(store_status)?
        {
            Ok(())
        } else {
            Err(Status::not_found(format!(
                "unknown worker `{id}` for this token: register first"
            )))
        }
    }

    async fn status_of(&self, id: &str) -> Result<pb::SubmissionStatus, Status> {
        let reader = self.store.reader();
        let sub = reader.submission(id).await.map_err(store_status)?;
        let p = reader.progress(id).await.map_err(store_status)?;
        // Throughput of the whole service over the last two minutes.
        let recent = reader
            .finished_since(now() - 120.0)
            .await
            .map_err(store_status)?;
        Ok(convert::status(&sub, &p, recent.rate()))
    }
}

/// gRPC `Coordinator` service.
pub struct CoordinatorApi(Arc<Coordinator>);

/// gRPC `WorkerPool` service.
pub struct WorkerPoolApi(Arc<Coordinator>);

pub(crate) type StatusStream = std::pin::Pin<
    Box<dyn tokio_stream::Stream<Item = Result<pb::SubmissionStatus, Status>> + Send>,
>;

fn check_id(id: &str) -> Result<(), Status> {
    if id.is_empty() || id.len() > 64 {
        return Err(Status::invalid_argument(
            "submission_id is empty or too long",
        ));
    }
    Ok(())
}

/// A gRPC server with the coordinator's two services (add more, e.g. the Sim API, before serving), over TLS when
/// `tls` is given ([`server_tls`]), with `limits`' keepalive; serve it on [`vb_net::grpc::incoming`] with the same
/// limits.
pub fn grpc_router(
    c: &Arc<Coordinator>,
    tls: Option<tonic::transport::ServerTlsConfig>,
    limits: &vb_net::Limits,
) -> Result<vb_net::grpc::Router, CoordinatorError> {
    let mut server = vb_net::grpc::server(limits);
    if let Some(tls) = tls {
        server = server
            .tls_config(tls)
            .map_err(|e| CoordinatorError::Tls(e.to_string()))?;
    }
    Ok(server
        .add_service(c.coordinator_service())
        .add_service(c.worker_pool_service()))
}

/// TLS settings of the coordinator's gRPC server from a PEM certificate chain and its PEM private key.
pub fn server_tls(
    cert: &std::path::Path,
    key: &std::path::Path,
) -> Result<tonic::transport::ServerTlsConfig, CoordinatorError> {
    let read = |p: &std::path::Path| {
        std::fs::read(p).map_err(|e| CoordinatorError::Tls(format!("{}: {e}", p.display())))
    };
    Ok(
        tonic::transport::ServerTlsConfig::new().identity(tonic::transport::Identity::from_pem(
            read(cert)?,
            read(key)?,
        )),
    )
}
