//! A worker's start: its connection to the coordinator (the worker token on every call), its registration (waiting
//! for a coordinator that is not up yet), and what it can run here (exec planners where they can be contained,
//! image planners where Docker runs), with what dead workers' planners left on this machine swept away.

use crate::*;
use std::time::Duration;
use tonic::transport::Channel;
use vb_proto::v1 as pb;
use vb_proto::v1::worker_pool_client::WorkerPoolClient;

/// Sends the worker token with every call.
#[derive(Clone)]
pub(crate) struct Auth(tonic::metadata::MetadataValue<tonic::metadata::Ascii>);

impl tonic::service::Interceptor for Auth {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        req.metadata_mut().insert("authorization", self.0.clone());
        Ok(req)
    }
}

pub(crate) type Client =
    WorkerPoolClient<tonic::service::interceptor::InterceptedService<Channel, Auth>>;

/// How this worker runs planners.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlannerPolicy {
    /// How long a started planner process may take to serve.
    pub(crate) startup: Duration,
    /// How exec planners are contained.
    pub(crate) containment: sandbox::Containment,
}

/// What this worker can run.
pub(crate) struct Capabilities {
    pub(crate) policy: PlannerPolicy,
    pub(crate) runs_exec: bool,
    pub(crate) runs_images: bool,
}

/// A client of the coordinator's worker API (connected on first use).
pub(crate) fn connect(cfg: &WorkerConfig) -> Result<Client, WorkerError> {
    let channel = tls::endpoint(&cfg.coordinator, cfg.tls_ca.as_deref())
        .map_err(|e| WorkerError::Address(cfg.coordinator.clone(), e))?
        .connect_timeout(Duration::from_secs(2))
        .tcp_nodelay(true)
        .connect_lazy();
    let auth = format!("Bearer {}", cfg.token.trim())
        .parse()
        .map_err(|_| WorkerError::Refused("the worker token is not valid header text".into()))?;
    Ok(WorkerPoolClient::with_interceptor(channel, Auth(auth))
        .max_encoding_message_size(crate::remote::MAX_WORKER_MESSAGE))
}

/// Registers with `slots`, waiting for the coordinator if it is not up yet; `None` if the worker is stopped first.
/// A definite refusal (another simulator version, a bad token) is an error.
pub(crate) async fn register(
    client: &mut Client,
    cfg: &WorkerConfig,
    slots: usize,
    shutdown: &tokio::sync::watch::Receiver<bool>,
) -> Result<Option<pb::RegisterResponse>, WorkerError> {
    loop {
        if *shutdown.borrow() {
            return Ok(None);
        }
        match client
            .register(pb::RegisterRequest {
                worker_name: cfg.name.clone(),
                slots: slots as u32,
                sim_version: SIM_VERSION.into(),
            })
            .await
        {
            Ok(r) => return Ok(Some(r.into_inner())),
            Err(s)
                if matches!(
                    s.code(),
                    tonic::Code::FailedPrecondition
                        | tonic::Code::InvalidArgument
                        | tonic::Code::Unauthenticated
                        | tonic::Code::PermissionDenied
                ) =>
            {
                return Err(WorkerError::Refused(s.message().into()))
            }
            Err(_) => tokio::time::sleep(Duration::from_millis(300)).await,
        }
    }
}

/// What this worker can run: exec planners only where they can be given namespaces of their own (a worker that
/// cannot contain them says so and leaves them to workers that can, rather than promising an isolation it does not
/// give); image planners only where Docker runs. Sweeps what planners of this machine's dead workers left (a
/// watchdog removes it unless the machine went down or the watchdog was killed): never anything of a worker not
/// proven dead.
pub(crate) async fn capabilities(cfg: &WorkerConfig) -> Capabilities {
    let (containment, runs_exec) = if cfg.allow_exec {
        match sandbox::Containment::probe(cfg.planner_user).await {
            Ok(c) => (c, true),
            Err(why) => {
                tracing::warn!(reason = %why, "exec planners are refused by this worker (left to other workers)");
                (sandbox::Containment::default(), false)
            }
        }
    } else {
        (sandbox::Containment::default(), false)
    };
    let policy = PlannerPolicy {
        startup: Duration::from_secs_f64(cfg.planner_startup_s.max(1.0)),
        containment,
    };
    let runs_images = cfg.allow_exec
        && match exec::docker_available().await {
            Ok(()) => true,
            Err(why) => {
                tracing::info!(reason = %why, "image planners are left to other workers");
                false
            }
        };
    if cfg.allow_exec {
        let swept = sandbox::reaper::sweep(runs_images).await;
        if swept != sandbox::reaper::Swept::default() {
            tracing::info!(
                containers = swept.containers,
                dirs = swept.dirs,
                "removed what planners of dead workers left"
            );
        }
    }
    Capabilities {
        policy,
        runs_exec,
        runs_images,
    }
}
