//! Imperfect perception: the layer between the simulator's truth and what a planner receives, applied at the
//! control rate by the episode runner (never inside the physics step; `sim-core` knows nothing of it).
//!
//! A [`Profile`] names the noise of five channels: state estimation ([`state`]), the elevation map built online
//! from a range sensor with occlusion and range-dependent noise ([`map`]), semantics through a confusion matrix
//! ([`semantics`]), obstacle detection ([`obstacles`]) and actuation ([`actuation`]). `ideal` is ground truth.
//! A [`Perception`] is one episode's layer: its noise is a pure function of the task, the run's seed and the
//! profile ([`rng`]), one stream per channel, so it is bit-identical at any thread count and the same for every
//! planner evaluated on the task.
//!
//! Deterministic and free of IO (callers read profile files): the same rules as `sim-core` (`clippy.toml`).

pub mod actuation;
pub mod belief;
pub mod map;
pub mod obstacles;
pub mod profile;
pub mod rng;
pub mod semantics;
pub mod state;
pub mod sync;

pub use map::OnlineMap;
pub use profile::{Profile, ProfileError, BUILTIN};

use contracts::TaskId;
use rng::{stream, Channel, EpisodeKey};
use sim_core::planner::{Action, VehicleState};
use sim_core::world::{Obstacle, Patch, World};

/// What the planner perceives at one control step.
#[derive(Clone, Copy, Debug)]
pub struct Perceived<'a> {
    /// The estimated state.
    pub state: VehicleState,
    /// The elevation map built so far (`None`: the map is given whole, as the world's heightmap).
    pub map: Option<&'a OnlineMap>,
    /// Each patch's class as the planner is told it, with the class's nominal surface.
    pub patches: &'a [Patch],
    /// The obstacles the planner knows of: those detected so far and this scan's phantoms.
    pub obstacles: &'a [Obstacle],
    /// All of it as one believed world (`belief::Belief`): what map-reading planners and crops read.
    pub belief: &'a belief::Belief,
}

/// One episode's perception layer.
pub struct Perception {
    estimator: state::StateEstimator,
    mapper: Option<map::Mapper>,
    detector: obstacles::Detector,
    actuator: actuation::Actuator,
    obstacles: Vec<Obstacle>,
    /// The believed world; it holds the classified patches.
    belief: belief::Belief,
    /// The profile degrades the maps: observations carry the belief.
    degrades_maps: bool,
    /// Obstacles are the truth (detection perfect and the map given whole): no scans.
    obstacles_exact: bool,
    scan_period: f64,
    next_scan: f64,
    range: f64,
    fov: f64,
    mount_height: f64,
    noise_k: f64,
}

/// Lengths (and speeds) of a profile at scale `s`.
fn scaled(p: &Profile, s: f64) -> Profile {
    let mut p = p.clone();
    p.state.position_sigma *= s;
    p.state.velocity_sigma *= s;
    p.state.velocity_bias *= s;
    p.elevation.range *= s;
    p.elevation.mount_height *= s;
    p.obstacles.detection_half_range *= s;
    p
}

impl Perception {
    /// The layer of task `task` (starting at `start`) of `world` in a run of seed `seed`; `max_steer`: the
    /// vehicle's largest road-wheel angle (rad), `control_dt`: the planner's control period (s).
    pub fn new(
        profile: &Profile,
        world: &World,
        task: TaskId,
        start: [f64; 2],
        seed: u64,
        max_steer: f64,
        control_dt: f64,
    ) -> Perception {
        let key = EpisodeKey {
            task,
            seed,
            profile: profile.hash(),
        };
        let p = scaled(profile, world.scale);
        let confusion = semantics::confusion(&p.semantics);
        let patches =
            semantics::believed_patches(world, &confusion, &mut stream(&key, Channel::Semantics));
        let e = &p.elevation;
        let obstacles_exact = !e.online && p.obstacles == profile::ObstacleNoise::default();
        Perception {
            estimator: state::StateEstimator::new(
                p.state.clone(),
                stream(&key, Channel::State),
                start,
            ),
            mapper: e
                .online
                .then(|| map::Mapper::new(world, stream(&key, Channel::Elevation))),
            detector: obstacles::Detector::new(
                p.obstacles.clone(),
                stream(&key, Channel::Obstacles),
                world,
            ),
            actuator: actuation::Actuator::new(
                &p.actuation,
                stream(&key, Channel::Actuation),
                max_steer,
                control_dt,
            ),
            belief: belief::Belief::new(world, patches, e.online),
            degrades_maps: profile.degrades_maps(),
            obstacles: if obstacles_exact {
                world.obstacles.clone()
            } else {
                Vec::new()
            },
            obstacles_exact,
            scan_period: if e.online {
                1.0 / e.update_hz
            } else {
                control_dt
            },
            next_scan: 0.0,
            range: if e.online { e.range } else { f64::INFINITY },
            fov: if e.online {
                e.fov_deg.to_radians()
            } else {
                std::f64::consts::TAU
            },
            mount_height: e.mount_height,
            noise_k: e.height_noise_k,
        }
    }

    /// What the planner perceives, given the true state (call once per control step, in order).
    pub fn observe(&mut self, world: &World, truth: &VehicleState) -> Perceived<'_> {
        if truth.time + 1e-9 >= self.next_scan {
            self.next_scan += self.scan_period;
            self.scan(world, truth);
        }
        Perceived {
            state: self.estimator.estimate(truth),
            map: self.mapper.as_ref().map(|m| &m.map),
            patches: &self.belief.world().patches,
            obstacles: &self.obstacles,
            belief: &self.belief,
        }
    }

    fn scan(&mut self, world: &World, truth: &VehicleState) {
        let scan = map::Scan {
            origin: [
                truth.position[0],
                truth.position[1],
                truth.position[2] + self.mount_height,
            ],
            heading: truth.yaw,
            range: self.range,
            fov: self.fov,
            noise_k: self.noise_k,
        };
        if let Some(m) = &mut self.mapper {
            m.scan(world, &scan);
        }
        if !self.obstacles_exact {
            self.detect(world, truth, &scan);
        }
        self.belief
            .update(self.mapper.as_ref().map(|m| &m.map), &self.obstacles);
    }

    fn detect(&mut self, world: &World, truth: &VehicleState, scan: &map::Scan) {
        let sensor = [truth.position[0], truth.position[1]];
        self.detector
            .scan(world, sensor, self.range, |x, y| scan.in_view(x, y));
        self.obstacles.clear();
        self.detector.detected(world, &mut self.obstacles);
        let fp_range = if self.range.is_finite() {
            self.range
        } else {
            world.heightmap.half_x().min(world.heightmap.half_y())
        };
        self.detector
            .phantoms(world, sensor, fp_range, &mut self.obstacles);
    }

    /// The action the vehicle applies for the planner's command (call once per control step).
    pub fn actuate(&mut self, command: Action) -> Action {
        self.actuator.apply(command)
    }
}

/// The layer as the episode runner's hook: the planner sees the estimated state and, under a profile that degrades
/// the maps, the believed world; the vehicle applies the actuated command.
impl sim_core::ControlHook for Perception {
    fn observe(&mut self, world: &World, obs: &mut sim_core::planner::Observation) {
        let degrades_maps = self.degrades_maps;
        let seen = Perception::observe(self, world, &obs.state);
        obs.state = seen.state;
        if degrades_maps {
            obs.belief = Some(seen.belief.shared());
        }
    }

    fn actuate(&mut self, command: Action) -> Action {
        Perception::actuate(self, command)
    }

    fn believed_world(&self) -> Option<&World> {
        self.degrades_maps.then(|| self.belief.world())
    }
}

/// The control hook of one episode under `profile`: [`sim_core::Truth`] under a profile that perturbs nothing
/// (every existing result stays bit-identical), else the episode's [`Perception`] (arguments as [`Perception::new`]).
pub fn hook(
    profile: &Profile,
    world: &World,
    task: TaskId,
    start: [f64; 2],
    seed: u64,
    max_steer: f64,
    control_dt: f64,
) -> Box<dyn sim_core::ControlHook> {
    if profile.is_ideal() {
        Box::new(sim_core::Truth)
    } else {
        Box::new(Perception::new(
            profile, world, task, start, seed, max_steer, control_dt,
        ))
    }
}
