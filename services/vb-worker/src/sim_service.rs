//! The client-driven simulator API (`vertibench.v1.Sim`): create an episode on a task, reset it, step it with an
//! action per call, read observations, reward terms and the world maps. A non-Python client drives episodes with it
//! (Python users have the SDK's in-process environments, which are much faster).
//!
//! Each episode is sim-core's [`EpisodeRun`], the state machine the benchmark's own runner drives, so a
//! client-driven episode follows exactly the rules (start, termination, metrics, action checks) of a benchmark
//! episode. Reward terms are [`sim_core::reward`]'s with the default weights: `progress` (m of goal distance gained,
//! full scale), `roll_penalty` and `pitch_penalty` (never positive: `-0.1 (angle / 30 deg)^2`), `terminal` (+10 on
//! success, -10 on any other end except the time limit). `truncated` is the time limit; every other end is
//! `terminated`.
//!
//! Who may call, whose each episode is and when an untouched one is closed: [`crate::sim_access`].

use crate::convert;
use crate::sim_access::{Client, SimAccess, PER_CLIENT};
use sim_core::episode::EpisodeConfig;
use sim_core::observe::CropSpec;
use sim_core::planner::Action;
use sim_core::vehicle::VehicleSpec;
use sim_core::world::{Task, World};
use sim_core::EpisodeRun;
use std::collections::HashMap;
use std::sync::Arc;
use tasks::TaskSet;
use tokio::sync::Mutex;
use tonic::{Request, Response, Status};
use vb_proto::v1 as pb;

/// Most episodes open at once per server.
pub const MAX_EPISODES: usize = 64;

struct SimEpisode {
    world: Arc<World>,
    task: Arc<Task>,
    vehicle: Arc<VehicleSpec>,
    cfg: EpisodeConfig,
    control_rate: f64,
    crop: Option<CropSpec>,
    run: Option<EpisodeRun>,
}

impl SimEpisode {
    fn observation(&self, run: &EpisodeRun) -> pb::Observation {
        convert::observation(&run.observation(), &self.world, self.crop.as_ref())
    }

    /// Starts the episode over: the vehicle settled at rest at the start.
    fn reset(&mut self) -> pb::StepResponse {
        let mut run =
            EpisodeRun::new_shared(self.world.clone(), &self.task, &self.vehicle, &self.cfg);
        run.set_control_rate(self.control_rate)
            .expect("the control rate was checked at creation");
        let resp = pb::StepResponse {
            observation: Some(self.observation(&run)),
            reward: Some(pb::RewardTerms::default()),
            terminated: false,
            truncated: false,
            outcome: String::new(),
        };
        self.run = Some(run);
        resp
    }

    /// One control step with `action`.
    fn step(&mut self, action: Action) -> Result<pb::StepResponse, Status> {
        let mut run = self
            .run
            .take()
            .ok_or_else(|| Status::failed_precondition("call Reset before Step"))?;
        if run.end().is_some() {
            self.run = Some(run);
            return Err(Status::failed_precondition(
                "the episode has ended: call Reset to start again",
            ));
        }
        // An invalid action ends the episode: `advance` then runs no physics and reports that end.
        let _ = run.control(action);
        let step = run.advance();
        let mut resp = pb::StepResponse {
            observation: Some(self.observation(&run)),
            terminated: step.terminated,
            truncated: step.truncated,
            ..Default::default()
        };
        if step.ended() {
            let result = run.finish();
            let outcome = result.outcome.as_str();
            resp.outcome = if result.reason.as_str() == outcome {
                outcome.to_string()
            } else {
                format!("{outcome}:{}", result.reason)
            };
        }
        let r = step.reward;
        resp.reward = Some(pb::RewardTerms {
            progress: r.progress,
            roll_penalty: r.roll,
            pitch_penalty: r.pitch,
            terminal: r.terminal,
        });
        self.run = Some(run);
        Ok(resp)
    }
}

/// An open episode with its owner and its last use.
struct Entry {
    owner: Client,
    last_used: std::time::Instant,
    episode: Arc<Mutex<SimEpisode>>,
}

/// The `Sim` gRPC service.
pub struct SimService {
    set: Arc<TaskSet>,
    access: SimAccess,
    episodes: Mutex<HashMap<String, Entry>>,
}

impl SimService {
    pub fn new(set: Arc<TaskSet>, access: SimAccess) -> SimService {
        SimService {
            set,
            access,
            episodes: Mutex::new(HashMap::new()),
        }
    }

    pub fn server(self) -> pb::sim_server::SimServer<SimService> {
        pb::sim_server::SimServer::new(self)
    }

    /// Serves the API alone on `listener` within `limits` (connection limit, first-request and idle timeouts,
    /// HTTP/2 keepalive) until the server fails.
    pub async fn serve(
        self,
        listener: tokio::net::TcpListener,
        limits: &vb_net::Limits,
    ) -> Result<(), tonic::transport::Error> {
        vb_net::grpc::server(limits)
            .add_service(self.server())
            .serve_with_incoming(vb_net::grpc::incoming(listener, limits, "Sim API"))
            .await
    }

    /// Episode `id` if it is `client`'s and still open (another client's reads as absent); marks its use.
    async fn get<T>(&self, req: &Request<T>, id: &str) -> Result<Arc<Mutex<SimEpisode>>, Status> {
        let client = self.access.client(req)?;
        let mut map = self.episodes.lock().await;
        let now = std::time::Instant::now();
        match map.get_mut(id) {
            Some(e) if e.owner == client && now.duration_since(e.last_used) < self.access.idle => {
                e.last_used = now;
                Ok(e.episode.clone())
            }
            _ => Err(Status::not_found(format!(
                "no episode `{id}` of yours (closed, expired after {:.0} s unused, or never created)",
                self.access.idle.as_secs_f64()
            ))),
        }
    }
}

/// What a create request asks for, checked: the vehicle (default `hmmwv`), the scale (0: the vehicle's own), the
/// control period (0: 0.05 s) and the local map crop.
struct Settings {
    vehicle: sim_core::VehicleSpec,
    scale: f64,
    control_dt: f64,
    crop: Option<CropSpec>,
}

fn settings(r: &pb::CreateEpisodeRequest) -> Result<Settings, Status> {
    let bad = Status::invalid_argument;
    let vname = if r.vehicle.is_empty() {
        "hmmwv"
    } else {
        &r.vehicle
    };
    let vehicle =
        sim_core::vehicle::vehicle_by_name(vname).map_err(|e| bad(format!("vehicle: {e}")))?;
    let scale = if r.scale == 0.0 {
        vehicle.scale
    } else {
        r.scale
    };
    if !(scale.is_finite() && scale > 0.0 && scale <= 1.0) {
        return Err(bad(format!("scale {} must be in (0, 1]", r.scale)));
    }
    let control_dt = if r.control_dt == 0.0 {
        0.05
    } else {
        r.control_dt
    };
    if !(control_dt.is_finite() && (0.001..=1.0).contains(&control_dt)) {
        return Err(bad(format!(
            "control_dt {} must be in [0.001, 1] s",
            r.control_dt
        )));
    }
    let crop = match r.local_map_size {
        0 => None,
        n if n <= 512 && r.local_map_resolution.is_finite() && r.local_map_resolution > 0.0 => {
            Some(CropSpec {
                size: n as usize,
                resolution: r.local_map_resolution,
            })
        }
        _ => {
            return Err(bad(
                "local_map_size must be <= 512 with a positive local_map_resolution".into(),
            ))
        }
    };
    Ok(Settings {
        vehicle,
        scale,
        control_dt,
        crop,
    })
}

/// A new episode id: `ep-` and 32 random hex digits.
fn episode_id() -> Result<String, Status> {
    let mut id_bytes = [0u8; 16];
    getrandom::getrandom(&mut id_bytes).map_err(|e| Status::internal(e.to_string()))?;
    let id = format!(
        "ep-{}",
        id_bytes
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect::<String>()
    );
    Ok(id)
}

impl SimService {
    /// Closes the episodes unused for the idle time, then refuses a new one beyond the client's and the server's
    /// limits.
    fn make_room(
        &self,
        map: &mut HashMap<String, Entry>,
        client: &Client,
        now: std::time::Instant,
    ) -> Result<(), Status> {
        map.retain(|_, e| now.duration_since(e.last_used) < self.access.idle);
        if map.values().filter(|e| e.owner == *client).count() >= PER_CLIENT {
            return Err(Status::resource_exhausted(format!(
            "you have {PER_CLIENT} episodes open on this server: close some first (unused ones close after \
             {:.0} s)",
            self.access.idle.as_secs_f64()
        )));
        }
        if map.len() >= MAX_EPISODES {
            return Err(Status::resource_exhausted(format!(
            "{MAX_EPISODES} episodes are open on this server: close some first (unused ones close after {:.0} s)",
            self.access.idle.as_secs_f64()
        )));
        }
        Ok(())
    }
}

#[tonic::async_trait]
impl pb::sim_server::Sim for SimService {
    async fn create_episode(
        &self,
        req: Request<pb::CreateEpisodeRequest>,
    ) -> Result<Response<pb::CreateEpisodeResponse>, Status> {
        let client = self.access.client(&req)?;
        let r = req.into_inner();
        let bad = Status::invalid_argument;
        let id: contracts::TaskId = r
            .task_id
            .parse()
            .map_err(|_| bad(format!("task_id `{}` is not like w017-t3", r.task_id)))?;
        let (w, t) = (id.world, id.index);
        let Settings {
            vehicle,
            scale,
            control_dt,
            crop,
        } = settings(&r)?;
        let world = self
            .set
            .world(w, scale)
            .map_err(|e| Status::not_found(e.to_string()))?;
        let task = self
            .set
            .tasks(w, scale)
            .map_err(|e| Status::not_found(e.to_string()))?
            .into_iter()
            .nth(t as usize)
            .ok_or_else(|| Status::not_found(format!("no task {t} in world {w}")))?;
        let task_info = convert::task_info(&task, &world, self.set.version());
        let info = convert::vehicle_info(&vehicle.info());
        let id = episode_id()?;
        let ep = SimEpisode {
            world: Arc::new(world),
            task: Arc::new(task),
            vehicle: Arc::new(vehicle),
            cfg: EpisodeConfig {
                seed: r.seed,
                ..EpisodeConfig::default()
            },
            control_rate: 1.0 / control_dt,
            crop,
            run: None,
        };
        let mut map = self.episodes.lock().await;
        let now = std::time::Instant::now();
        self.make_room(&mut map, &client, now)?;
        map.insert(
            id.clone(),
            Entry {
                owner: client,
                last_used: now,
                episode: Arc::new(Mutex::new(ep)),
            },
        );
        Ok(Response::new(pb::CreateEpisodeResponse {
            episode_id: id,
            task: Some(task_info),
            vehicle: Some(info),
        }))
    }

    async fn reset(
        &self,
        req: Request<pb::ResetRequest>,
    ) -> Result<Response<pb::StepResponse>, Status> {
        let ep = self.get(&req, &req.get_ref().episode_id).await?;
        let mut ep = ep.lock_owned().await;
        let resp = tokio::task::spawn_blocking(move || ep.reset())
            .await
            .map_err(|e| Status::internal(e.to_string()))?;
        Ok(Response::new(resp))
    }

    async fn step(
        &self,
        req: Request<pb::StepRequest>,
    ) -> Result<Response<pb::StepResponse>, Status> {
        let ep = self.get(&req, &req.get_ref().episode_id).await?;
        let r = req.into_inner();
        let action = r
            .action
            .ok_or_else(|| Status::invalid_argument("step without an action"))?;
        let mut ep = ep.lock_owned().await;
        let resp = tokio::task::spawn_blocking(move || ep.step(convert::action(&action)))
            .await
            .map_err(|e| Status::internal(e.to_string()))??;
        Ok(Response::new(resp))
    }

    async fn get_maps(
        &self,
        req: Request<pb::GetMapsRequest>,
    ) -> Result<Response<pb::WorldMaps>, Status> {
        let ep = self.get(&req, &req.get_ref().episode_id).await?;
        let ep = ep.lock().await;
        Ok(Response::new(convert::world_maps(&ep.world)))
    }

    async fn close_episode(
        &self,
        req: Request<pb::CloseEpisodeRequest>,
    ) -> Result<Response<pb::CloseEpisodeResponse>, Status> {
        let id = &req.get_ref().episode_id;
        self.get(&req, id).await?;
        self.episodes.lock().await.remove(id);
        Ok(Response::new(pb::CloseEpisodeResponse {}))
    }
}
