//! The planner interface: what every mobility system (built-in baseline, remote gRPC planner, RL policy) implements.
//!
//! The episode runner calls [`Planner::reset`] once with the task and the ground-truth maps, then
//! [`Planner::act`] at the planner's control rate. Simulated time is frozen while the planner thinks, so results do
//! not depend on the planner's hardware. A planner that fails returns a [`PlannerError`]; the episode then ends with
//! that failure reason and nothing else is affected.

use crate::world::{Task, World};
use contracts::EndReason;
use serde::{Deserialize, Serialize};

use crate::vehicle::VehicleSpec;
/// The vehicle's controls and what it reports live with the vehicle ([`crate::vehicle`]); planners see them here.
pub use crate::vehicle::{Action, VehicleInfo, VehicleState};

/// What the planner receives at every control step.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Observation {
    pub state: VehicleState,
    /// The world as the planner perceives it under a perception profile that degrades the maps (the `perception`
    /// crate's believed world: heights `NaN` where not yet seen, classified patches, the obstacles known); `None`
    /// under ground truth, where the context's world is the truth. Not serialised.
    #[serde(skip)]
    pub belief: Option<std::sync::Arc<World>>,
}

/// Everything a planner gets at the start of an episode.
#[derive(Clone, Copy, Debug)]
pub struct PlannerContext<'a> {
    pub world: &'a World,
    pub task: &'a Task,
    pub vehicle: &'a VehicleInfo,
    /// The vehicle's full model parameters (mass, suspension, tyres, powertrain), as a team knows its own
    /// vehicle: model-based planners may build a model from it (MPPI-6 simulates it).
    pub spec: &'a VehicleSpec,
    /// Physics step of the simulator, s (informative).
    pub sim_dt: f64,
    /// `world` is the planner's belief at the start, not the truth (a perception profile that degrades the maps:
    /// heights `NaN` until seen, patches as classified, no obstacles yet), and each observation's `belief` is the
    /// world as perceived so far.
    pub believed: bool,
}

/// Why a planner could not act. The episode runner records the kind as the failure reason.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlannerError {
    #[error("planner timed out: {0}")]
    Timeout(String),
    #[error("planner crashed: {0}")]
    Crashed(String),
    #[error("planner protocol error: {0}")]
    Protocol(String),
    #[error("planner failed: {0}")]
    Other(String),
}

impl PlannerError {
    /// Stable machine-readable failure reason.
    pub fn reason(&self) -> EndReason {
        match self {
            Self::Timeout(_) => EndReason::PlannerTimeout,
            Self::Crashed(_) => EndReason::PlannerCrash,
            Self::Protocol(_) => EndReason::PlannerProtocol,
            Self::Other(_) => EndReason::PlannerError,
        }
    }
}

/// A mobility system driving one episode at a time.
pub trait Planner: Send {
    /// Short identifier, e.g. `pid`.
    fn name(&self) -> &str;
    /// How often `act` is called, Hz.
    fn control_rate_hz(&self) -> f64;
    /// Prepare for a new episode.
    fn reset(&mut self, ctx: &PlannerContext<'_>) -> Result<(), PlannerError>;
    /// Choose the next action.
    fn act(&mut self, obs: &Observation) -> Result<Action, PlannerError>;
    /// Whether the planner reads the world's maps (heights, patches, obstacles) from [`PlannerContext::world`]:
    /// a perception profile that degrades the maps refuses such a planner, which would see the truth through the
    /// context. Planners that follow only the task's path and the state (PID, pure pursuit) say `false`.
    fn reads_world_maps(&self) -> bool {
        true
    }
    /// Whether the planner reads the maps from [`Observation::belief`] when it is given, and copes with its unknown
    /// cells: a profile that degrades the maps then runs it.
    fn reads_belief(&self) -> bool {
        false
    }
    /// Whether a profile that degrades the maps may run the planner: it reads no map, or reads the belief. The one
    /// rule `vb eval`, the worker and the service's catalogue apply.
    fn runs_on_degraded_maps(&self) -> bool {
        !self.reads_world_maps() || self.reads_belief()
    }
}
