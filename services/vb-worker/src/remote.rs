//! A planner reached over gRPC: one bidirectional `PlanEpisode` stream per episode, driven in lock-step.
//!
//! [`RemotePlanner`] implements sim-core's synchronous [`Planner`] trait so the same episode runner drives built-in
//! and remote planners. It is used on a blocking thread and waits on the tokio runtime for each answer, with a
//! deadline per control step: a slow planner fails its episode with `planner_timeout`, a dead one with
//! `planner_crash`, and simulated time is frozen meanwhile, so results do not depend on the planner's hardware.

use crate::convert;
use perception::sync::MapSync;
use sim_core::observe::CropSpec;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::world::World;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tokio::runtime::Handle;
use tokio::sync::mpsc;
use tonic::transport::{Channel, Endpoint};
use vb_proto::v1 as pb;
use vb_proto::v1::planner_client::PlannerClient;

/// Largest message a planner may send (its answers are small; this bounds a misbehaving one).
pub const MAX_PLANNER_MESSAGE: usize = 1 << 20;
/// Largest message the worker sends (the episode start carries the world maps).
pub const MAX_WORKER_MESSAGE: usize = 16 << 20;
/// Longest name a planner may announce in `Info` (as long as a submission's name may be).
pub const MAX_PLANNER_NAME: usize = 100;

/// The planner's log (its `log` fields and, for processes the worker started, stdout and stderr), capped.
#[derive(Debug, Default)]
pub struct PlannerLog {
    text: String,
    dropped: usize,
    /// Output streams of a process still being read into this log.
    open_streams: usize,
}

impl PlannerLog {
    pub const CAP: usize = 64 << 10;

    /// A process's output stream starts being read into the log.
    pub fn stream_opened(&mut self) {
        self.open_streams += 1;
    }

    /// That stream reached its end: everything the process wrote to it is in the log.
    pub fn stream_closed(&mut self) {
        self.open_streams = self.open_streams.saturating_sub(1);
    }

    pub fn push_line(&mut self, line: &str) {
        if self.text.len() + line.len() + 1 > Self::CAP {
            self.dropped += 1;
            return;
        }
        self.text.push_str(line);
        self.text.push('\n');
    }

    pub fn text(&self) -> String {
        if self.dropped > 0 {
            format!(
                "{}[{} more lines dropped: log cap {} bytes]\n",
                self.text,
                self.dropped,
                Self::CAP
            )
        } else {
            self.text.clone()
        }
    }

    /// The last `n` bytes, for error messages.
    pub fn tail(&self, n: usize) -> String {
        let t = &self.text;
        let mut cut = t.len().saturating_sub(n);
        while !t.is_char_boundary(cut) {
            cut += 1;
        }
        t[cut..].trim_end().to_string()
    }
}

pub type SharedLog = Arc<Mutex<PlannerLog>>;

fn push_log(log: &SharedLog, line: &str) {
    if let Ok(mut l) = log.lock() {
        l.push_line(line);
    }
}

struct Session {
    tx: mpsc::Sender<pb::WorkerMessage>,
    rx: tonic::Streaming<pb::PlannerMessage>,
}

/// A planner server reached over gRPC.
pub struct RemotePlanner {
    rt: Handle,
    endpoint: String,
    client: PlannerClient<Channel>,
    info: pb::PlannerInfo,
    crop: Option<CropSpec>,
    step_deadline: Duration,
    start_deadline: Duration,
    session: Option<Session>,
    world: Option<World>,
    /// The planner's believed maps under a map-degrading perception profile (`None` under ground truth).
    sync: Option<MapSync>,
    task_set_version: String,
    seed: u64,
    perception: String,
    log: SharedLog,
    /// Extra context for crash messages (e.g. the tail of a planner process's stderr).
    crash_context: Option<SharedLog>,
    /// Round-trip time of every control step, s (observation sent to action received).
    pub round_trips: Vec<f64>,
}

/// The crops a planner's `Info` asks for (`None`: none), checked.
fn crop_spec(info: &pb::PlannerInfo) -> Result<Option<CropSpec>, PlannerError> {
    Ok(match info.local_map_size {
        0 => None,
        n if n > 512 => {
            return Err(PlannerError::Protocol(format!(
                "planner announced local_map_size {n}; it must be at most 512"
            )));
        }
        n => {
            let r = info.local_map_resolution;
            if !(r.is_finite() && r > 0.0) {
                return Err(PlannerError::Protocol(format!(
                    "planner announced local_map_resolution {r}; it must be positive when local_map_size is set"
                )));
            }
            Some(CropSpec {
                size: n as usize,
                resolution: r,
            })
        }
    })
}

fn status_error(what: &str, s: &tonic::Status) -> PlannerError {
    match s.code() {
        tonic::Code::DeadlineExceeded => PlannerError::Timeout(format!("{what}: {}", s.message())),
        tonic::Code::Unimplemented | tonic::Code::InvalidArgument | tonic::Code::OutOfRange => {
            PlannerError::Protocol(format!("{what}: {} ({:?})", s.message(), s.code()))
        }
        _ => PlannerError::Crashed(format!("{what}: {} ({:?})", s.message(), s.code())),
    }
}

impl RemotePlanner {
    /// Connects to a planner server and asks for its [`pb::PlannerInfo`]. Call from async code; use the planner
    /// from a blocking thread.
    pub async fn connect(
        endpoint: &str,
        step_deadline: Duration,
        connect_timeout: Duration,
    ) -> Result<RemotePlanner, PlannerError> {
        let connected = if let Some(path) = endpoint.strip_prefix("unix:") {
            // A Unix socket (image planners, which have no network); the URI is not used.
            let path = path.to_string();
            Endpoint::from_static("http://planner.socket")
                .connect_timeout(connect_timeout)
                .connect_with_connector(tower::service_fn(move |_: tonic::transport::Uri| {
                    let path = path.clone();
                    async move {
                        let stream = tokio::net::UnixStream::connect(path).await?;
                        Ok::<_, std::io::Error>(hyper_util::rt::TokioIo::new(stream))
                    }
                }))
                .await
        } else {
            Endpoint::from_shared(endpoint.to_string())
                .map_err(|e| {
                    PlannerError::Other(format!("bad planner endpoint `{endpoint}`: {e}"))
                })?
                .connect_timeout(connect_timeout)
                .tcp_nodelay(true)
                .connect()
                .await
        };
        let channel = connected.map_err(|e| {
            PlannerError::Crashed(format!("cannot connect to planner at {endpoint}: {e}"))
        })?;
        let mut client = PlannerClient::new(channel)
            .max_decoding_message_size(MAX_PLANNER_MESSAGE)
            .max_encoding_message_size(MAX_WORKER_MESSAGE);
        let start_deadline = step_deadline.max(Duration::from_secs(10));
        let info = match tokio::time::timeout(start_deadline, client.info(pb::InfoRequest {})).await
        {
            Err(_) => {
                return Err(PlannerError::Timeout(format!(
                    "planner at {endpoint} did not answer Info within {:.1} s",
                    start_deadline.as_secs_f64()
                )))
            }
            Ok(Err(s)) => return Err(status_error("Info", &s)),
            Ok(Ok(r)) => r.into_inner(),
        };
        let rate = info.control_rate_hz;
        if !(rate.is_finite() && rate > 0.0 && rate <= 1000.0) {
            return Err(PlannerError::Protocol(format!(
                "planner announced control rate {rate} Hz (Info.control_rate_hz); it must be in (0, 1000] Hz"
            )));
        }
        if info.name.chars().count() > MAX_PLANNER_NAME {
            return Err(PlannerError::Protocol(format!(
                "planner announced a name of {} characters (Info.name); it must be at most {MAX_PLANNER_NAME}",
                info.name.chars().count()
            )));
        }
        if let Err(e) = contracts::input::check_display_text("Info.name", &info.name) {
            return Err(PlannerError::Protocol(format!(
                "planner announced a name that cannot be shown as it is ({e})"
            )));
        }
        let crop = crop_spec(&info)?;
        Ok(RemotePlanner {
            rt: Handle::current(),
            endpoint: endpoint.to_string(),
            client,
            info,
            crop,
            step_deadline,
            start_deadline,
            session: None,
            world: None,
            sync: None,
            task_set_version: String::new(),
            seed: 0,
            perception: "ideal".into(),
            log: Arc::new(Mutex::new(PlannerLog::default())),
            crash_context: None,
            round_trips: Vec::new(),
        })
    }

    /// Sets what goes into `EpisodeStart` besides the task and the maps.
    pub fn set_episode_context(&mut self, task_set_version: &str, seed: u64) {
        self.task_set_version = task_set_version.into();
        self.seed = seed;
    }

    /// The run's perception profile, as `EpisodeStart` names it (default `ideal`).
    pub fn set_perception(&mut self, identity: &str) {
        self.perception = identity.into();
    }

    /// Shares a log: the planner's `log` lines are appended to it.
    pub fn set_log(&mut self, log: SharedLog) {
        self.log = log;
    }

    /// A log whose tail is quoted when the planner crashes (a process's stderr).
    pub fn set_crash_context(&mut self, log: SharedLog) {
        self.crash_context = Some(log);
    }

    pub fn info(&self) -> &pb::PlannerInfo {
        &self.info
    }

    pub fn log(&self) -> SharedLog {
        self.log.clone()
    }

    fn crashed(&self, msg: String) -> PlannerError {
        let tail = self
            .crash_context
            .as_ref()
            .map(|log| {
                // The process's last words may still be in its pipes when its connection drops: wait (on this
                // blocking thread) until its output ends, a moment at most.
                let t0 = std::time::Instant::now();
                while log.lock().is_ok_and(|l| l.open_streams > 0)
                    && t0.elapsed() < Duration::from_millis(500)
                {
                    std::thread::sleep(Duration::from_millis(5));
                }
                log.lock().map(|l| l.tail(600)).unwrap_or_default()
            })
            .unwrap_or_default();
        if tail.is_empty() {
            PlannerError::Crashed(msg)
        } else {
            PlannerError::Crashed(format!("{msg}; last planner output:\n{tail}"))
        }
    }

    /// Sends one message (unless it was queued already) and waits for the answer within `deadline`.
    fn exchange(
        &mut self,
        msg: Option<pb::WorkerMessage>,
        deadline: Duration,
        what: &str,
    ) -> Result<pb::PlannerMessage, PlannerError> {
        let session = self.session.as_mut().ok_or_else(|| {
            PlannerError::Protocol("no episode session (reset was not called)".into())
        })?;
        let res = self.rt.block_on(tokio::time::timeout(deadline, async {
            if let Some(msg) = msg {
                if session.tx.send(msg).await.is_err() {
                    return Err(None);
                }
            }
            session.rx.message().await.map_err(Some)
        }));
        match res {
            Err(_) => Err(PlannerError::Timeout(format!(
                "no answer to {what} within {:.3} s",
                deadline.as_secs_f64()
            ))),
            Ok(Err(None)) => Err(self.crashed(format!(
                "planner at {} closed the episode stream",
                self.endpoint
            ))),
            Ok(Err(Some(s))) => Err(match status_error(what, &s) {
                PlannerError::Crashed(m) => self.crashed(m),
                other => other,
            }),
            Ok(Ok(None)) => Err(self.crashed(format!(
                "planner at {} ended the episode stream before answering {what}",
                self.endpoint
            ))),
            Ok(Ok(Some(m))) => {
                if !m.log.is_empty() {
                    for line in m.log.lines() {
                        push_log(&self.log, line);
                    }
                }
                Ok(m)
            }
        }
    }

    /// Tells the planner how the episode ended and closes the stream.
    pub fn finish(&mut self, outcome: &str, reason: impl std::fmt::Display) {
        if let Some(s) = self.session.take() {
            let end = pb::WorkerMessage {
                msg: Some(pb::worker_message::Msg::End(pb::EpisodeEnd {
                    outcome: outcome.into(),
                    reason: reason.to_string(),
                })),
            };
            // Best effort: the planner may already be gone.
            let _ = s.tx.try_send(end);
        }
    }
}

impl Planner for RemotePlanner {
    fn name(&self) -> &str {
        if self.info.name.is_empty() {
            "remote"
        } else {
            &self.info.name
        }
    }

    fn control_rate_hz(&self) -> f64 {
        self.info.control_rate_hz
    }

    /// Its maps and crops are the believed world's under a map-degrading profile (`EpisodeStart.believed`).
    fn reads_belief(&self) -> bool {
        true
    }

    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        self.finish("aborted", "reset");
        let start = pb::EpisodeStart {
            task: Some(convert::task_info(
                ctx.task,
                ctx.world,
                &self.task_set_version,
            )),
            vehicle: Some(convert::vehicle_info(ctx.vehicle)),
            maps: Some(convert::world_maps(ctx.world)),
            sim_dt: ctx.sim_dt,
            seed: self.seed,
            believed: ctx.believed,
            perception: self.perception.clone(),
        };
        let (tx, rx) = mpsc::channel::<pb::WorkerMessage>(2);
        // `EpisodeStart` is queued before the stream opens: a server may send its response headers only with its
        // first answer (grpcio does), so waiting for them before sending anything would deadlock.
        tx.try_send(pb::WorkerMessage {
            msg: Some(pb::worker_message::Msg::Start(start)),
        })
        .map_err(|e| PlannerError::Other(format!("queueing EpisodeStart: {e}")))?;
        let mut client = self.client.clone();
        let opened = self.rt.block_on(tokio::time::timeout(
            self.start_deadline,
            client.plan_episode(tokio_stream::wrappers::ReceiverStream::new(rx)),
        ));
        let stream = match opened {
            Err(_) => {
                return Err(PlannerError::Timeout(format!(
                "planner did not open the episode stream and answer EpisodeStart within {:.1} s",
                self.start_deadline.as_secs_f64()
            )))
            }
            Ok(Err(s)) => return Err(status_error("PlanEpisode", &s)),
            Ok(Ok(r)) => r.into_inner(),
        };
        self.session = Some(Session { tx, rx: stream });
        self.world = Some(ctx.world.clone());
        self.sync = ctx.believed.then(|| MapSync::new(ctx.world));
        let deadline = self.start_deadline;
        match self.exchange(None, deadline, "EpisodeStart")?.msg {
            Some(pb::planner_message::Msg::Ready(_)) => Ok(()),
            other => Err(PlannerError::Protocol(format!(
                "expected `ready` in answer to EpisodeStart, got {other:?}"
            ))),
        }
    }

    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let world = match (&obs.belief, &self.world) {
            (Some(b), _) => b.as_ref(),
            (None, Some(w)) => w,
            (None, None) => return Err(PlannerError::Protocol("act before reset".into())),
        };
        let mut observation = convert::observation(obs, world, self.crop.as_ref());
        if let (Some(sync), Some(b)) = (&mut self.sync, &obs.belief) {
            observation.map_update = sync.update(b).map(|p| convert::map_update(&p, world));
        }
        let msg = pb::WorkerMessage {
            msg: Some(pb::worker_message::Msg::Observation(observation)),
        };
        let t0 = Instant::now();
        let deadline = self.step_deadline;
        let answer = self.exchange(
            Some(msg),
            deadline,
            &format!("the observation at t = {:.2} s", obs.state.time),
        );
        self.round_trips.push(t0.elapsed().as_secs_f64());
        match answer?.msg {
            Some(pb::planner_message::Msg::Action(a)) => Ok(convert::action(&a)),
            other => Err(PlannerError::Protocol(format!(
                "expected an action in answer to an observation, got {other:?}"
            ))),
        }
    }
}
