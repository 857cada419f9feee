//! An example vertibench planner: a gRPC `Planner` server that follows the task's global path with pure pursuit
//! and holds a cruising speed. Copy this crate to start your own planner.
//!
//! ```text
//! example-planner [--addr HOST:PORT] [--fault KIND] [--fault-after N] [--delay-ms MS] [--control-rate-hz HZ]
//! ```
//! The address defaults to `$VB_PLANNER_ADDR` (set by workers that start the planner for an `exec` or `image`
//! submission: `127.0.0.1:PORT`, or `unix:PATH` in a container without network), else `127.0.0.1:50061`. `--fault` makes it misbehave after N control steps, to test how the service copes:
//! `crash` (exit 3), `hang` (never answer), `nan` (a NaN steering command), `range` (throttle 5.0).
//! `--delay-ms` sleeps before every answer (a slow but well-behaved planner); `--control-rate-hz` announces another
//! control rate than 10 Hz (an invalid one tests how the service reports a planner's protocol error).

// tonic::Status is large (176 bytes) and is the error type of every gRPC handler; boxing it everywhere buys nothing.
#![allow(clippy::result_large_err)]

use anyhow::Context;
use std::pin::Pin;
use std::time::Duration;
use tokio_stream::{Stream, StreamExt};
use tonic::{Request, Response, Status, Streaming};
use vb_proto::v1 as pb;
use vb_proto::v1::planner_server::{Planner, PlannerServer};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Fault {
    None,
    Crash,
    Hang,
    Nan,
    Range,
}

#[derive(Clone, Debug)]
struct Options {
    fault: Fault,
    fault_after: u64,
    delay: Duration,
    /// The control rate announced in `Info` (10 Hz; `--control-rate-hz` announces another, even an invalid one).
    control_rate_hz: f64,
    /// The name announced in `Info` (`--name` announces another, even one a worker refuses).
    name: String,
}

/// The planner's believed heights under a perception profile that builds the map online (`EpisodeStart.believed`):
/// `NaN` until the sensor sees a cell, then kept up to date from each observation's `MapUpdate`. This planner only
/// follows its path; a planner that reads terrain keeps the map this way.
struct BelievedMap {
    nx: usize,
    heights: Vec<f32>,
    updates: usize,
}

impl BelievedMap {
    fn new(start: &pb::EpisodeStart) -> Option<BelievedMap> {
        let e = start.maps.as_ref()?.elevation.as_ref()?;
        start.believed.then(|| BelievedMap {
            nx: e.nx as usize,
            heights: e.data.clone(),
            updates: 0,
        })
    }

    /// Pastes the update's rectangle of heights (ignoring one that does not fit the grid).
    fn update(&mut self, u: &pb::MapUpdate) {
        let Some(e) = &u.elevation else { return };
        let (x0, y0, w) = (u.x0 as usize, u.y0 as usize, e.nx as usize);
        for (r, row) in e.data.chunks(w.max(1)).enumerate() {
            let at = (y0 + r) * self.nx + x0;
            if x0 + w <= self.nx && at + w <= self.heights.len() {
                self.heights[at..at + w].copy_from_slice(row);
            }
        }
        self.updates += 1;
    }

    fn describe(&self) -> String {
        let known = self.heights.iter().filter(|z| z.is_finite()).count();
        format!(
            "believed map: {known} of {} heights known after {} updates",
            self.heights.len(),
            self.updates
        )
    }
}

/// Per-episode state: the path, the vehicle's geometry and the cruising speed.
struct Driver {
    path: Vec<(f64, f64)>,
    goal: (f64, f64),
    wheelbase: f64,
    max_steer: f64,
    skid: bool,
    cruise: f64,
    lookahead: f64,
    progress: usize,
}

impl Driver {
    fn new(start: &pb::EpisodeStart) -> Result<Driver, String> {
        let task = start.task.as_ref().ok_or("EpisodeStart without task")?;
        let v = start
            .vehicle
            .as_ref()
            .ok_or("EpisodeStart without vehicle")?;
        let goal = task.goal.as_ref().map(|g| (g.x, g.y)).unwrap_or_default();
        let mut path: Vec<(f64, f64)> = task.global_path.iter().map(|p| (p.x, p.y)).collect();
        if path.is_empty() {
            path.push(goal);
        }
        Ok(Driver {
            path,
            goal,
            wheelbase: v.wheelbase.max(0.1),
            max_steer: if v.skid_steer {
                0.5
            } else {
                v.max_steer.max(0.05)
            },
            skid: v.skid_steer,
            cruise: v.nominal_speed.max(0.1),
            lookahead: 10.0 * task.scale.max(0.01),
            progress: 0,
        })
    }

    fn act(&mut self, s: &pb::VehicleState) -> pb::Action {
        // Advance along the path past points already within the look-ahead distance.
        let (x, y) = (s.x, s.y);
        let d = |p: (f64, f64)| ((p.0 - x).powi(2) + (p.1 - y).powi(2)).sqrt();
        while self.progress + 1 < self.path.len() && d(self.path[self.progress]) < self.lookahead {
            self.progress += 1;
        }
        let target = if d(self.goal) < self.lookahead {
            self.goal
        } else {
            self.path[self.progress]
        };
        let heading = (target.1 - y).atan2(target.0 - x);
        let alpha = wrap(heading - s.yaw);
        let steering = if self.skid {
            (2.0 * alpha).clamp(-1.0, 1.0)
        } else {
            let dist = d(target).max(1e-3);
            let delta = (2.0 * self.wheelbase * alpha.sin() / dist).atan();
            (delta / self.max_steer).clamp(-1.0, 1.0)
        };
        let speed_error = self.cruise - s.speed;
        let throttle = (0.5 + 0.5 * speed_error / self.cruise).clamp(0.0, 1.0);
        pb::Action {
            steering,
            throttle,
            brake: 0.0,
        }
    }
}

fn wrap(a: f64) -> f64 {
    let mut a = a % std::f64::consts::TAU;
    if a > std::f64::consts::PI {
        a -= std::f64::consts::TAU;
    } else if a < -std::f64::consts::PI {
        a += std::f64::consts::TAU;
    }
    a
}

/// The answer to control step `steps`: the driver's action (made faulty as `--fault` asks), with what the planner
/// knows of the map now and then (kept with the episode's log).
fn answer(
    opts: &Options,
    steps: u64,
    driver: Option<&mut Driver>,
    believed: Option<&BelievedMap>,
    state: Option<pb::VehicleState>,
) -> Result<pb::PlannerMessage, Status> {
    let (Some(d), Some(s)) = (driver, state) else {
        return Err(Status::failed_precondition(
            "observation before EpisodeStart",
        ));
    };
    let mut a = d.act(&s);
    if steps > opts.fault_after {
        match opts.fault {
            Fault::Nan => a.steering = f64::NAN,
            Fault::Range => a.throttle = 5.0,
            _ => {}
        }
    }
    Ok(pb::PlannerMessage {
        msg: Some(pb::planner_message::Msg::Action(a)),
        log: match believed {
            Some(b) if steps.is_multiple_of(50) => b.describe(),
            _ => String::new(),
        },
    })
}

struct ExamplePlanner {
    opts: Options,
}

type AnswerStream = Pin<Box<dyn Stream<Item = Result<pb::PlannerMessage, Status>> + Send>>;

#[tonic::async_trait]
impl Planner for ExamplePlanner {
    async fn info(&self, _: Request<pb::InfoRequest>) -> Result<Response<pb::PlannerInfo>, Status> {
        Ok(Response::new(pb::PlannerInfo {
            name: self.opts.name.clone(),
            version: env!("CARGO_PKG_VERSION").into(),
            control_rate_hz: self.opts.control_rate_hz,
            local_map_size: 0,
            local_map_resolution: 0.0,
        }))
    }

    type PlanEpisodeStream = AnswerStream;

    async fn plan_episode(
        &self,
        req: Request<Streaming<pb::WorkerMessage>>,
    ) -> Result<Response<Self::PlanEpisodeStream>, Status> {
        let mut inbound = req.into_inner();
        let opts = self.opts.clone();
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        tokio::spawn(async move {
            let mut driver: Option<Driver> = None;
            let mut believed: Option<BelievedMap> = None;
            let mut steps = 0u64;
            while let Some(msg) = inbound.next().await {
                let msg = match msg {
                    Ok(m) => m,
                    Err(_) => break,
                };
                use pb::worker_message::Msg;
                let answer = match msg.msg {
                    Some(Msg::Start(start)) => match Driver::new(&start) {
                        Ok(d) => {
                            let id = start
                                .task
                                .as_ref()
                                .map(|t| t.task_id.clone())
                                .unwrap_or_default();
                            eprintln!("example-planner: episode {id} started");
                            driver = Some(d);
                            believed = BelievedMap::new(&start);
                            Ok(pb::PlannerMessage {
                                msg: Some(pb::planner_message::Msg::Ready(true)),
                                log: format!("ready for {id}"),
                            })
                        }
                        Err(e) => Err(Status::invalid_argument(e)),
                    },
                    Some(Msg::Observation(obs)) => {
                        steps += 1;
                        if let (Some(b), Some(u)) = (&mut believed, &obs.map_update) {
                            b.update(u);
                        }
                        if steps > opts.fault_after {
                            match opts.fault {
                                Fault::Crash => {
                                    eprintln!(
                                        "example-planner: crashing on purpose (--fault crash)"
                                    );
                                    std::process::exit(3);
                                }
                                Fault::Hang => {
                                    eprintln!("example-planner: hanging on purpose (--fault hang)");
                                    tokio::time::sleep(Duration::from_secs(3600)).await;
                                }
                                _ => {}
                            }
                        }
                        if !opts.delay.is_zero() {
                            tokio::time::sleep(opts.delay).await;
                        }
                        answer(&opts, steps, driver.as_mut(), believed.as_ref(), obs.state)
                    }
                    Some(Msg::End(end)) => {
                        eprintln!(
                            "example-planner: episode ended: {} ({})",
                            end.outcome, end.reason
                        );
                        if let Some(b) = &believed {
                            eprintln!("example-planner: {}", b.describe());
                        }
                        break;
                    }
                    None => Err(Status::invalid_argument("empty message")),
                };
                let stop = answer.is_err();
                if tx.send(answer).await.is_err() || stop {
                    break;
                }
            }
        });
        Ok(Response::new(Box::pin(
            tokio_stream::wrappers::ReceiverStream::new(rx),
        )))
    }
}

fn parse_args() -> anyhow::Result<(String, Options)> {
    let mut addr = std::env::var("VB_PLANNER_ADDR").unwrap_or_else(|_| "127.0.0.1:50061".into());
    let mut opts = Options {
        fault: Fault::None,
        fault_after: 0,
        delay: Duration::ZERO,
        control_rate_hz: 10.0,
        name: "example-pure-pursuit".into(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().with_context(|| format!("{a} needs a value"));
        match a.as_str() {
            "--addr" => addr = value()?,
            "--fault" => {
                opts.fault = match value()?.as_str() {
                    "crash" => Fault::Crash,
                    "hang" => Fault::Hang,
                    "nan" => Fault::Nan,
                    "range" => Fault::Range,
                    "none" => Fault::None,
                    other => {
                        anyhow::bail!("unknown --fault `{other}` (crash, hang, nan, range, none)")
                    }
                }
            }
            "--fault-after" => opts.fault_after = value()?.parse().context("--fault-after")?,
            "--control-rate-hz" => {
                opts.control_rate_hz = value()?.parse().context("--control-rate-hz")?
            }
            "--name" => opts.name = value()?,
            "--delay-ms" => {
                opts.delay = Duration::from_millis(value()?.parse().context("--delay-ms")?)
            }
            "-h" | "--help" => {
                println!("example-planner [--addr HOST:PORT] [--fault crash|hang|nan|range] [--fault-after N] [--delay-ms MS] [--control-rate-hz HZ] [--name NAME]");
                std::process::exit(0);
            }
            other => anyhow::bail!("unknown argument `{other}` (see --help)"),
        }
    }
    Ok((addr, opts))
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let (addr, opts) = parse_args()?;
    let service = PlannerServer::new(ExamplePlanner { opts }).max_decoding_message_size(16 << 20);
    let server = tonic::transport::Server::builder()
        .tcp_nodelay(true)
        .add_service(service);
    if let Some(path) = addr.strip_prefix("unix:") {
        // Image planners have no network: the worker gives them a Unix socket.
        let listener = tokio::net::UnixListener::bind(path)
            .with_context(|| format!("cannot listen on {addr}"))?;
        eprintln!("example-planner: serving vertibench.v1.Planner on {addr}");
        let incoming = tokio_stream::wrappers::UnixListenerStream::new(listener);
        server.serve_with_incoming(incoming).await
    } else {
        let sock: std::net::SocketAddr = addr
            .parse()
            .with_context(|| format!("bad address `{addr}`"))?;
        eprintln!("example-planner: serving vertibench.v1.Planner on {sock}");
        server.serve(sock).await
    }
    .context("planner server failed")?;
    Ok(())
}
