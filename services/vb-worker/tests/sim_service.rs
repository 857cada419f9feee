//! The client-driven Sim API over real gRPC: create, reset, step to the end, reward terms, determinism, errors.

use std::sync::Arc;
use tokio_stream::wrappers::TcpListenerStream;
use vb_proto::v1 as pb;
use vb_proto::v1::sim_client::SimClient;
use vb_worker::sim_access::SimAccess;
use vb_worker::sim_service::SimService;

async fn server() -> anyhow::Result<SimClient<tonic::transport::Channel>> {
    let addr = server_with(SimAccess::loopback_only()).await?;
    Ok(SimClient::connect(format!("http://{addr}")).await?)
}

/// A Sim server with `access`; its address.
async fn server_with(access: SimAccess) -> anyhow::Result<std::net::SocketAddr> {
    let set = Arc::new(tasks::TaskSet::committed()?);
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let addr = listener.local_addr()?;
    tokio::spawn(
        tonic::transport::Server::builder()
            .add_service(SimService::new(set, access).server())
            .serve_with_incoming(TcpListenerStream::new(listener)),
    );
    Ok(addr)
}

/// A request carrying `token`.
fn with_token<T>(msg: T, token: &str) -> tonic::Request<T> {
    let mut r = tonic::Request::new(msg);
    r.metadata_mut()
        .insert("authorization", format!("Bearer {token}").parse().unwrap());
    r
}

fn create(task: &str) -> pb::CreateEpisodeRequest {
    pb::CreateEpisodeRequest {
        task_id: task.into(),
        ..Default::default()
    }
}

/// Issue 58, point 3: with tokens, a call without one (or with another) is refused; an episode is its creator's
/// (another client's token finds nothing); unused episodes expire and give their places back; one client holds
/// at most its share.
#[tokio::test]
async fn the_sim_api_needs_a_token_episodes_are_their_owners_and_unused_ones_expire(
) -> anyhow::Result<()> {
    use vb_worker::sim_access::PER_CLIENT;
    let access = SimAccess::with_tokens(["alice".to_string(), "bob".to_string()])
        .with_idle(std::time::Duration::from_millis(1500));
    let addr = server_with(access).await?;
    let mut c = SimClient::connect(format!("http://{addr}")).await?;
    let e = c.create_episode(create("w001-t0")).await.unwrap_err();
    assert_eq!(e.code(), tonic::Code::Unauthenticated, "{e:?}");
    let e = c
        .create_episode(with_token(create("w001-t0"), "mallory"))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::Unauthenticated, "{e:?}");
    let id = c
        .create_episode(with_token(create("w001-t0"), "alice"))
        .await?
        .into_inner()
        .episode_id;
    c.reset(with_token(
        pb::ResetRequest {
            episode_id: id.clone(),
        },
        "alice",
    ))
    .await?;
    // Bob has the id but not the episode: nothing to reset, step or close.
    let e = c
        .reset(with_token(
            pb::ResetRequest {
                episode_id: id.clone(),
            },
            "bob",
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e:?}");
    let e = c
        .close_episode(with_token(
            pb::CloseEpisodeRequest {
                episode_id: id.clone(),
            },
            "bob",
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e:?}");
    // Alice fills her share; one more is refused, Bob still gets one.
    for _ in 1..PER_CLIENT {
        c.create_episode(with_token(create("w001-t0"), "alice"))
            .await?;
    }
    let e = c
        .create_episode(with_token(create("w001-t0"), "alice"))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::ResourceExhausted, "{e:?}");
    c.create_episode(with_token(create("w001-t0"), "bob"))
        .await?;
    // Alice goes away: her episodes expire and her share is hers again.
    tokio::time::sleep(std::time::Duration::from_millis(1800)).await;
    let e = c
        .reset(with_token(
            pb::ResetRequest {
                episode_id: id.clone(),
            },
            "alice",
        ))
        .await
        .unwrap_err();
    assert_eq!(e.code(), tonic::Code::NotFound, "{e:?}");
    for _ in 0..PER_CLIENT {
        c.create_episode(with_token(create("w001-t0"), "alice"))
            .await?;
    }
    Ok(())
}

/// Steers toward the goal at a moderate throttle.
fn drive(obs: &pb::Observation, goal: &pb::Vec2) -> pb::Action {
    let s = obs.state.unwrap_or_default();
    let heading = (goal.y - s.y).atan2(goal.x - s.x);
    let mut err = heading - s.yaw;
    while err > std::f64::consts::PI {
        err -= std::f64::consts::TAU;
    }
    while err < -std::f64::consts::PI {
        err += std::f64::consts::TAU;
    }
    pb::Action {
        steering: (1.5 * err).clamp(-1.0, 1.0),
        throttle: 0.5,
        brake: 0.0,
    }
}

/// Runs one episode to its end; returns every state's position and the sums of the reward terms.
async fn run(
    client: &mut SimClient<tonic::transport::Channel>,
    id: &str,
    goal: &pb::Vec2,
) -> anyhow::Result<(Vec<(f64, f64, f64)>, f64, pb::StepResponse)> {
    let mut r = client
        .reset(pb::ResetRequest {
            episode_id: id.into(),
        })
        .await?
        .into_inner();
    let mut states = Vec::new();
    let mut progress = 0.0;
    for _ in 0..5000 {
        let obs = r.observation.clone().unwrap_or_default();
        let s = obs.state.unwrap_or_default();
        states.push((s.time, s.x, s.y));
        if r.terminated || r.truncated {
            return Ok((states, progress, r));
        }
        r = client
            .step(pb::StepRequest {
                episode_id: id.into(),
                action: Some(drive(&obs, goal)),
            })
            .await?
            .into_inner();
        progress += r.reward.unwrap_or_default().progress;
    }
    anyhow::bail!("episode did not end")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn client_driven_episode_runs_to_the_end_deterministically() -> anyhow::Result<()> {
    let mut client = server().await?;
    let created = client
        .create_episode(pb::CreateEpisodeRequest {
            task_id: "w001-t0".into(),
            control_dt: 0.1,
            local_map_size: 16,
            local_map_resolution: 0.5,
            ..Default::default()
        })
        .await?
        .into_inner();
    let task = created.task.clone().unwrap();
    let (start, goal) = (task.start.unwrap(), task.goal.unwrap());
    assert_eq!(created.vehicle.unwrap().name, "hmmwv");
    let id = created.episode_id.clone();
    let maps = client
        .get_maps(pb::GetMapsRequest {
            episode_id: id.clone(),
        })
        .await?
        .into_inner();
    let elev = maps.elevation.unwrap();
    assert_eq!((elev.nx, elev.ny, elev.data.len()), (129, 129, 129 * 129));

    let (states, progress, last) = run(&mut client, &id, &goal).await?;
    // Observations come every control_dt of simulated time, starting at rest at the start.
    assert_eq!(states[0].0, 0.0);
    assert!(((states[0].1 - start.x).powi(2) + (states[0].2 - start.y).powi(2)).sqrt() < 1.0);
    assert!(
        (states[1].0 - 0.1).abs() < 0.01,
        "second observation at t = {}",
        states[1].0
    );
    assert!(!last.outcome.is_empty());
    assert!(last.terminated || last.truncated);
    // The progress terms add up to the decrease of the distance to the goal.
    let d0 = ((goal.x - start.x).powi(2) + (goal.y - start.y).powi(2)).sqrt();
    let end = states.last().unwrap();
    let d_end = ((goal.x - end.1).powi(2) + (goal.y - end.2).powi(2)).sqrt();
    assert!(
        (progress - (d0 - d_end)).abs() < 1.0,
        "sum of progress {progress} vs distance decrease {}",
        d0 - d_end
    );
    assert!(
        progress > 5.0,
        "the vehicle should make progress toward the goal: {progress}"
    );
    // Heading-aligned local maps came with every observation.
    let local = last.observation.unwrap().local.unwrap();
    assert_eq!(local.elevation.unwrap().data.len(), 16 * 16);
    // The same actions from a reset give the same trajectory, bit for bit.
    let (again, _, _) = run(&mut client, &id, &goal).await?;
    assert_eq!(states, again);
    // Stepping a finished episode is refused until the next reset.
    let err = client
        .step(pb::StepRequest {
            episode_id: id.clone(),
            action: Some(pb::Action::default()),
        })
        .await
        .unwrap_err();
    assert_eq!(err.code(), tonic::Code::FailedPrecondition, "{err}");
    client
        .close_episode(pb::CloseEpisodeRequest {
            episode_id: id.clone(),
        })
        .await?;
    let err = client
        .reset(pb::ResetRequest { episode_id: id })
        .await
        .unwrap_err();
    assert_eq!(err.code(), tonic::Code::NotFound);
    Ok(())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn invalid_actions_and_requests_get_clear_answers() -> anyhow::Result<()> {
    let mut client = server().await?;
    let id = client
        .create_episode(pb::CreateEpisodeRequest {
            task_id: "w002-t1".into(),
            ..Default::default()
        })
        .await?
        .into_inner()
        .episode_id;
    let err = client
        .step(pb::StepRequest {
            episode_id: id.clone(),
            action: Some(pb::Action::default()),
        })
        .await
        .unwrap_err();
    assert_eq!(
        err.code(),
        tonic::Code::FailedPrecondition,
        "step before reset: {err}"
    );
    client
        .reset(pb::ResetRequest {
            episode_id: id.clone(),
        })
        .await?;
    let r = client
        .step(pb::StepRequest {
            episode_id: id.clone(),
            action: Some(pb::Action {
                steering: f64::NAN,
                throttle: 0.5,
                brake: 0.0,
            }),
        })
        .await?
        .into_inner();
    assert!(r.terminated);
    assert_eq!(r.outcome, "planner_failure:invalid_action");
    assert_eq!(r.reward.unwrap().terminal, -10.0);
    for (req, code) in [
        (
            pb::CreateEpisodeRequest {
                task_id: "banana".into(),
                ..Default::default()
            },
            tonic::Code::InvalidArgument,
        ),
        (
            pb::CreateEpisodeRequest {
                task_id: "w999-t0".into(),
                ..Default::default()
            },
            tonic::Code::NotFound,
        ),
        (
            pb::CreateEpisodeRequest {
                task_id: "w001-t0".into(),
                vehicle: "tank-9000".into(),
                ..Default::default()
            },
            tonic::Code::InvalidArgument,
        ),
        (
            pb::CreateEpisodeRequest {
                task_id: "w001-t0".into(),
                control_dt: -1.0,
                ..Default::default()
            },
            tonic::Code::InvalidArgument,
        ),
    ] {
        let err = client.create_episode(req.clone()).await.unwrap_err();
        assert_eq!(err.code(), code, "{req:?}: {err}");
        assert!(!err.message().is_empty());
    }
    let err = client
        .step(pb::StepRequest {
            episode_id: "ep-nope".into(),
            action: Some(pb::Action::default()),
        })
        .await
        .unwrap_err();
    assert_eq!(err.code(), tonic::Code::NotFound);
    Ok(())
}
