//! The client-driven simulator API (`vertibench.v1.Sim`): create an episode on a task, reset it, step it with an
//! action per call, read observations, reward terms and the world maps. The Python SDK's gymnasium environment
//! wraps it.
//!
//! Each episode runs sim-core's own episode runner on a thread of its own, with a planner whose `act` hands the
//! observation to the client and waits for the client's next action. So a client-driven episode follows exactly the
//! rules (termination, metrics, action checks) of a benchmark episode.
//!
//! Reward terms per step: `progress` = decrease of the horizontal distance to the goal (m); `roll_penalty` and
//! `pitch_penalty` = -(angle / rollover threshold)^2 at the new state; `terminal` = +10 on success, -10 on
//! rollover, -5 when stuck, -10 on a rejected action, 0 otherwise. `terminated` covers success, rollover, stuck and
//! rejected actions; `truncated` covers the time limit and leaving the map.

use crate::convert;
use sim_core::episode::{EpisodeConfig, EpisodeResult, Outcome};
use sim_core::observe::CropSpec;
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::vehicle::VehicleSpec;
use sim_core::world::{Task, World};
use std::collections::HashMap;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender};
use std::sync::Arc;
use tasks::TaskSet;
use tokio::sync::Mutex;
use tonic::{Request, Response, Status};
use vb_proto::v1 as pb;

/// Most episodes open at once per server.
pub const MAX_EPISODES: usize = 64;

enum FromSim {
    Observation(Observation),
    Done(Box<EpisodeResult>),
}

/// The planner side of a client-driven episode.
struct ClientPlanner {
    rate: f64,
    to_client: SyncSender<FromSim>,
    from_client: Receiver<Action>,
}

impl Planner for ClientPlanner {
    fn name(&self) -> &str {
        "client"
    }
    fn control_rate_hz(&self) -> f64 {
        self.rate
    }
    fn reset(&mut self, _: &PlannerContext<'_>) -> Result<(), PlannerError> {
        Ok(())
    }
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        self.to_client
            .send(FromSim::Observation(obs.clone()))
            .map_err(|_| PlannerError::Other("episode closed".into()))?;
        self.from_client
            .recv()
            .map_err(|_| PlannerError::Other("episode closed".into()))
    }
}

struct Running {
    to_sim: SyncSender<Action>,
    from_sim: Receiver<FromSim>,
    last: Option<Observation>,
    done: bool,
}

struct SimEpisode {
    world: Arc<World>,
    task: Arc<Task>,
    vehicle: Arc<VehicleSpec>,
    cfg: EpisodeConfig,
    control_dt: f64,
    crop: Option<CropSpec>,
    running: Option<Running>,
}

impl SimEpisode {
    fn start(&mut self) -> Running {
        let (to_client, from_sim) = sync_channel(1);
        let (to_sim, from_client) = sync_channel(1);
        let (world, task, vehicle, cfg) = (
            self.world.clone(),
            self.task.clone(),
            self.vehicle.clone(),
            self.cfg.clone(),
        );
        let rate = 1.0 / self.control_dt;
        std::thread::spawn(move || {
            let mut planner = ClientPlanner {
                rate,
                to_client: to_client.clone(),
                from_client,
            };
            let r = sim_core::run_episode(&world, &task, &vehicle, &mut planner, &cfg);
            let _ = to_client.send(FromSim::Done(Box::new(r)));
        });
        Running {
            to_sim,
            from_sim,
            last: None,
            done: false,
        }
    }
}

fn goal_distance(obs: &Observation, task: &Task) -> f64 {
    let p = obs.state.position;
    ((task.goal[0] - p[0]).powi(2) + (task.goal[1] - p[1]).powi(2)).sqrt()
}

/// The `Sim` gRPC service.
pub struct SimService {
    set: Arc<TaskSet>,
    episodes: Mutex<HashMap<String, Arc<Mutex<SimEpisode>>>>,
}

impl SimService {
    pub fn new(set: Arc<TaskSet>) -> SimService {
        SimService {
            set,
            episodes: Mutex::new(HashMap::new()),
        }
    }

    pub fn server(self) -> pb::sim_server::SimServer<SimService> {
        pb::sim_server::SimServer::new(self)
    }

    async fn get(&self, id: &str) -> Result<Arc<Mutex<SimEpisode>>, Status> {
        self.episodes.lock().await.get(id).cloned().ok_or_else(|| {
            Status::not_found(format!("no episode `{id}` (closed, or never created)"))
        })
    }

    fn response(
        ep: &SimEpisode,
        run: &mut Running,
        msg: FromSim,
        prev: Option<&Observation>,
    ) -> pb::StepResponse {
        let limit = ep.cfg.rollover_deg.to_radians();
        match msg {
            FromSim::Observation(obs) => {
                let progress = prev.map_or(0.0, |p| {
                    goal_distance(p, &ep.task) - goal_distance(&obs, &ep.task)
                });
                let reward = pb::RewardTerms {
                    progress,
                    roll_penalty: -(obs.state.roll / limit).powi(2),
                    pitch_penalty: -(obs.state.pitch / limit).powi(2),
                    terminal: 0.0,
                };
                let o = convert::observation(&obs, &ep.world, ep.crop.as_ref());
                run.last = Some(obs);
                pb::StepResponse {
                    observation: Some(o),
                    reward: Some(reward),
                    terminated: false,
                    truncated: false,
                    outcome: String::new(),
                }
            }
            FromSim::Done(r) => {
                run.done = true;
                let (terminated, truncated, terminal) = match r.outcome {
                    Outcome::Success => (true, false, 10.0),
                    Outcome::Rollover => (true, false, -10.0),
                    Outcome::Stuck => (true, false, -5.0),
                    Outcome::PlannerFailure => (true, false, -10.0),
                    Outcome::Timeout | Outcome::OffMap => (false, true, 0.0),
                };
                let final_distance = r.metrics.final_goal_distance;
                let progress = prev.map_or(0.0, |p| goal_distance(p, &ep.task) - final_distance);
                let outcome = if r.reason.is_empty() || r.reason == r.outcome.as_str() {
                    r.outcome.as_str().to_string()
                } else {
                    format!("{}:{}", r.outcome.as_str(), r.reason)
                };
                pb::StepResponse {
                    observation: run
                        .last
                        .as_ref()
                        .map(|o| convert::observation(o, &ep.world, ep.crop.as_ref())),
                    reward: Some(pb::RewardTerms {
                        progress,
                        roll_penalty: 0.0,
                        pitch_penalty: 0.0,
                        terminal,
                    }),
                    terminated,
                    truncated,
                    outcome,
                }
            }
        }
    }
}

fn recv(run: &Running) -> Result<FromSim, Status> {
    run.from_sim
        .recv()
        .map_err(|_| Status::internal("the episode thread stopped unexpectedly"))
}

#[tonic::async_trait]
impl pb::sim_server::Sim for SimService {
    async fn create_episode(
        &self,
        req: Request<pb::CreateEpisodeRequest>,
    ) -> Result<Response<pb::CreateEpisodeResponse>, Status> {
        let r = req.into_inner();
        let bad = Status::invalid_argument;
        let (w, t) = crate::parse_task_id(&r.task_id)
            .ok_or_else(|| bad(format!("task_id `{}` is not like w017-t3", r.task_id)))?;
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
        let mut id_bytes = [0u8; 8];
        getrandom::getrandom(&mut id_bytes).map_err(|e| Status::internal(e.to_string()))?;
        let id = format!(
            "ep-{}",
            id_bytes
                .iter()
                .map(|b| format!("{b:02x}"))
                .collect::<String>()
        );
        let ep = SimEpisode {
            world: Arc::new(world),
            task: Arc::new(task),
            vehicle: Arc::new(vehicle),
            cfg: EpisodeConfig {
                seed: r.seed,
                ..EpisodeConfig::default()
            },
            control_dt,
            crop,
            running: None,
        };
        let mut map = self.episodes.lock().await;
        if map.len() >= MAX_EPISODES {
            return Err(Status::resource_exhausted(format!(
                "{MAX_EPISODES} episodes are open on this server: close some first"
            )));
        }
        map.insert(id.clone(), Arc::new(Mutex::new(ep)));
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
        let ep = self.get(&req.get_ref().episode_id).await?;
        let mut ep = ep.lock_owned().await;
        let resp = tokio::task::spawn_blocking(move || {
            // Dropping the old channels ends the previous run's thread.
            ep.running = None;
            let mut run = ep.start();
            let msg = recv(&run)?;
            let resp = SimService::response(&ep, &mut run, msg, None);
            ep.running = Some(run);
            Ok::<_, Status>(resp)
        })
        .await
        .map_err(|e| Status::internal(e.to_string()))??;
        Ok(Response::new(resp))
    }

    async fn step(
        &self,
        req: Request<pb::StepRequest>,
    ) -> Result<Response<pb::StepResponse>, Status> {
        let r = req.into_inner();
        let action = r
            .action
            .ok_or_else(|| Status::invalid_argument("step without an action"))?;
        let ep = self.get(&r.episode_id).await?;
        let mut ep = ep.lock_owned().await;
        let resp = tokio::task::spawn_blocking(move || {
            let mut run = ep
                .running
                .take()
                .ok_or_else(|| Status::failed_precondition("call Reset before Step"))?;
            if run.done {
                ep.running = Some(run);
                return Err(Status::failed_precondition(
                    "the episode has ended: call Reset to start again",
                ));
            }
            let prev = run.last.clone();
            run.to_sim
                .send(convert::action(&action))
                .map_err(|_| Status::internal("the episode thread stopped unexpectedly"))?;
            let msg = recv(&run)?;
            let resp = SimService::response(&ep, &mut run, msg, prev.as_ref());
            ep.running = Some(run);
            Ok(resp)
        })
        .await
        .map_err(|e| Status::internal(e.to_string()))??;
        Ok(Response::new(resp))
    }

    async fn get_maps(
        &self,
        req: Request<pb::GetMapsRequest>,
    ) -> Result<Response<pb::WorldMaps>, Status> {
        let ep = self.get(&req.get_ref().episode_id).await?;
        let ep = ep.lock().await;
        Ok(Response::new(convert::world_maps(&ep.world)))
    }

    async fn close_episode(
        &self,
        req: Request<pb::CloseEpisodeRequest>,
    ) -> Result<Response<pb::CloseEpisodeResponse>, Status> {
        let id = &req.get_ref().episode_id;
        self.episodes
            .lock()
            .await
            .remove(id)
            .ok_or_else(|| Status::not_found(format!("no episode `{id}`")))?;
        Ok(Response::new(pb::CloseEpisodeResponse {}))
    }
}
