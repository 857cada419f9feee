//! [`LearnedPlanner`]: a weights file's policy as a [`Planner`]: at every control step it computes the features of
//! `POLICY.md` from the ground-truth state, the goal and its own crops of the world, exactly as the Python SDK
//! gives them to training, and sends the actor's deterministic action (brake 0).

use crate::features::{
    crop_features, vector_features, Scales, CROP_CELL_PER_SCALE, CROP_CHANNELS, CROP_SIZE,
};
use crate::net::PolicyNet;
use sim_core::observe::{
    goal_vector, obstacle_crop, relative_elevation_crop, state_vector, CropSpec,
};
use sim_core::planner::{Action, Observation, Planner, PlannerContext, PlannerError};
use sim_core::world::World;

/// Control rate of a weights file without a `control_rate_hz` entry, Hz.
pub const DEFAULT_RATE_HZ: f64 = 20.0;

/// A learned policy driving episodes.
#[derive(Clone, Debug)]
pub struct LearnedPlanner {
    name: String,
    net: PolicyNet,
    rate_hz: f64,
    episode: Option<Episode>,
    elevation: Vec<f32>,
    obstacles: Vec<u8>,
    crop: Vec<f32>,
}

#[derive(Clone, Debug)]
struct Episode {
    world: World,
    goal: [f64; 2],
    scales: Scales,
    spec: CropSpec,
    last_throttle: f64,
}

impl LearnedPlanner {
    /// The policy of `net`, reported as `name`, acting at the rate its metadata gives.
    pub fn new(name: &str, net: PolicyNet) -> LearnedPlanner {
        let rate_hz = net
            .metadata()
            .get("control_rate_hz")
            .and_then(|r| r.parse().ok())
            .unwrap_or(DEFAULT_RATE_HZ);
        let n = CROP_SIZE * CROP_SIZE;
        LearnedPlanner {
            name: name.to_string(),
            net,
            rate_hz,
            episode: None,
            elevation: vec![0.0; n],
            obstacles: vec![0; n],
            crop: vec![0.0; CROP_CHANNELS * n],
        }
    }

    /// The network it runs.
    pub fn net(&self) -> &PolicyNet {
        &self.net
    }
}

impl Planner for LearnedPlanner {
    fn name(&self) -> &str {
        &self.name
    }

    fn control_rate_hz(&self) -> f64 {
        self.rate_hz
    }

    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError> {
        if let Some(trained) = self.net.metadata().get("vehicle") {
            if trained != &ctx.vehicle.name {
                return Err(PlannerError::Other(format!(
                    "policy `{}` was trained for the {trained}; this episode's vehicle is the {}",
                    self.name, ctx.vehicle.name
                )));
            }
        }
        let scale = ctx.vehicle.scale;
        self.episode = Some(Episode {
            world: ctx.world.clone(),
            goal: ctx.task.goal,
            scales: Scales {
                scale,
                nominal_speed: ctx.vehicle.nominal_speed,
            },
            spec: CropSpec {
                size: CROP_SIZE,
                resolution: scale * CROP_CELL_PER_SCALE,
            },
            last_throttle: 0.0,
        });
        Ok(())
    }

    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError> {
        let ep = self
            .episode
            .as_mut()
            .ok_or_else(|| PlannerError::Other("act before reset".into()))?;
        let s = &obs.state;
        relative_elevation_crop(&ep.world, s, &ep.spec, &mut self.elevation);
        obstacle_crop(&ep.world, s, &ep.spec, &mut self.obstacles);
        crop_features(
            &self.elevation,
            &self.obstacles,
            ep.scales.scale,
            &mut self.crop,
        );
        let vector = vector_features(
            &state_vector(s),
            &goal_vector(s, ep.goal),
            ep.last_throttle,
            &ep.scales,
        );
        let [steering, throttle] = self.net.act(&vector, &self.crop);
        ep.last_throttle = f64::from(throttle);
        Ok(Action {
            steering: f64::from(steering),
            throttle: f64::from(throttle),
            brake: 0.0,
        })
    }
}
