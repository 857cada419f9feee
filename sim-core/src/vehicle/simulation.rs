//! [`Simulation`], what it reports ([`StepInfo`], [`WheelReport`]), its options, and the named constants of the
//! model. Its parts: the parameters (`params.rs`), the dynamic state (`dynamics.rs`), the step's scratch
//! (`scratch.rs`). Building it is in `build.rs`, the step in `step.rs`.

use super::dynamics::DynamicsState;
use super::params::VehicleParams;
use super::scratch::StepScratch;
use crate::collide::ObstacleSet;
use crate::world::World;
use nalgebra::Vector3;
use std::sync::Arc;

pub(super) const G: f64 = 9.81;
/// Rim sample angles (rad) and lateral offsets (fraction of the half width) of the wheel contact.
pub(super) const RIM_ANGLES: [f64; 7] = [
    -1.047_197_551_196_597_6,
    -0.698_131_700_797_731_8,
    -0.349_065_850_398_865_9,
    0.0,
    0.349_065_850_398_865_9,
    0.698_131_700_797_731_8,
    1.047_197_551_196_597_6,
];
/// `(sin, cos)` of [`RIM_ANGLES`] (-60 .. 60 degrees in steps of 20), precomputed: no trigonometry in the step loop.
pub(super) const RIM_SIN_COS: [(f64, f64); 7] = [
    (-0.866_025_403_784_438_6, 0.5),
    (-0.642_787_609_686_539_4, 0.766_044_443_118_978),
    (-0.342_020_143_325_668_7, 0.939_692_620_785_908_4),
    (0.0, 1.0),
    (0.342_020_143_325_668_7, 0.939_692_620_785_908_4),
    (0.642_787_609_686_539_4, 0.766_044_443_118_978),
    (0.866_025_403_784_438_6, 0.5),
];
/// Static tyre deflection of the rigid-ground tyre at full scale, m (sets the tyre's vertical stiffness).
pub(super) const TYRE_STATIC_DEFLECTION: f64 = 0.01;
/// Rise of the ground per metre rolled for a wheel climbing out of a soil rut onto a rigid patch.
pub(super) const RUT_EXIT_SLOPE: f64 = 0.5;
pub(super) const RIM_LATERAL: [f64; 3] = [-0.66, 0.0, 0.66];
/// Fraction of the total mass carried by each wheel as unsprung mass.
pub(super) const UNSPRUNG_FRACTION: f64 = 0.04;
/// Samples per side of the grid over the footprint to which the start pose's plane is fitted.
pub(super) const FOOTPRINT_SAMPLES: usize = 5;
/// Settling at the start (scaled by sqrt(scale)): at most this long, s ...
pub const SETTLE_MAX: f64 = 10.0;
/// ... until every part moved slower than this for [`SETTLED_FOR`], m/s ...
pub const SETTLED_SPEED: f64 = 2e-3;
/// ... seconds.
pub const SETTLED_FOR: f64 = 1.0;
/// Time over which [`Simulation::settle`] ramps gravity up from zero, s (times sqrt(scale)): more than twice the
/// longest heave period on soft soil (about 0.9 s on snow), so the soil yields quasi-statically to its static
/// sinkage rather than the deeper one of an impact.
pub const LOAD_RAMP: f64 = 2.0;
/// Damping ratio of the tyre's bristle on rigid ground and of the soil's elastic shear (of critical, for the
/// wheel's share of the vehicle's mass).
pub(super) const BRISTLE_DAMPING_RATIO: f64 = 0.7;
/// Slip speed above which the soil's shear damping fades out, m/s (times sqrt(scale)).
pub(super) const SHEAR_DAMPING_SPEED: f64 = 0.05;
/// Magic-Formula coefficients of the handling tyre (Pacejka's dry-tarmac set: stiffness, shape, curvature).
pub(super) const MF_B: f64 = 10.0;
pub(super) const MF_C: f64 = 1.9;
pub(super) const MF_E: f64 = 0.97;
/// Deflection under the static load per wheel (times scale) that sets the rigid tyre's bristle stiffness, m.
pub(super) const BRISTLE_STATIC_DEFLECTION: f64 = 0.005;
/// Penetration under the whole weight on four points (times scale) that sets the body-ground contact stiffness, m.
pub(super) const BODY_CONTACT_DEFLECTION: f64 = 0.02;
/// Penetration under the whole weight (times scale) that sets the obstacle contact stiffness, m.
pub(super) const OBSTACLE_CONTACT_DEFLECTION: f64 = 0.002;
/// Damping ratios (of critical) of the tyre's vertical deflection, the body-ground and the obstacle contacts.
pub(super) const TYRE_DAMPING_RATIO: f64 = 0.5;
pub(super) const BODY_DAMPING_RATIO: f64 = 0.7;
pub(super) const OBSTACLE_DAMPING_RATIO: f64 = 0.5;
/// Sliding speed (times sqrt(scale)) below which the body's Coulomb friction is regularised (linear in speed), m/s.
pub(super) const BODY_FRICTION_SPEED: f64 = 0.05;
/// Coulomb friction between the body and rocks or trees (regularised below [`BODY_FRICTION_SPEED`], unscaled).
pub(super) const OBSTACLE_FRICTION: f64 = 0.5;
/// Slack of the obstacle near list beyond the vehicle's reach (times scale), m: at 30 m/s the vehicle covers 2.4 m
/// between refreshes.
pub(super) const OBSTACLE_NEAR_SLACK: f64 = 15.0;
/// Bump-stop stiffness as a multiple of the suspension spring rate.
pub(super) const BUMP_STOP_STIFFNESS: f64 = 20.0;
/// Steps between refreshes of the obstacle near list (its radius has 15 m of slack at full scale: 80 ms at 30 m/s
/// covers 2.4 m).
pub(super) const OBSTACLE_REFRESH_STEPS: u64 = 20;

/// What one step produced (for metrics).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// Mechanical power delivered by the powertrain to the wheels, W (positive when driving).
    pub drive_power: f64,
    /// Whether any part of the vehicle touches an obstacle.
    pub obstacle_contact: bool,
}

/// What one wheel (or track contact) is doing, for scenario tests and datasheets ([`Simulation::wheels`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelReport {
    /// Whether it touches the ground, and whether that ground is soil.
    pub contact: bool,
    pub soil: bool,
    /// Sinkage below the undeformed soil surface on soil, tyre deflection on rigid ground, m.
    pub sinkage: f64,
    /// Ground force on the wheel (normal load plus friction or soil force), world frame, N; and its part along the
    /// contact normal, N.
    pub force: [f64; 3],
    pub normal_load: f64,
    /// Longitudinal slip `(omega r - v) / max(|omega r|, |v|)`: positive when driving, -1 locked while moving.
    pub slip: f64,
    /// Whether the wheel is on the vehicle's left.
    pub left: bool,
    /// Spin, rad/s; suspension compression from full droop, m.
    pub spin: f64,
    pub compression: f64,
    /// The soil's torque on the wheel about its axle, N m (positive along a forward spin); 0 off soil.
    pub soil_torque: f64,
}

/// Options of [`Simulation::with_options`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimOptions {
    /// Physics step, s (`None`: [`default_dt`] of the vehicle's scale).
    pub dt: Option<f64>,
    /// Gravity, world frame, m/s^2.
    pub gravity: [f64; 3],
}

impl Default for SimOptions {
    fn default() -> Self {
        SimOptions {
            dt: None,
            gravity: [0.0, 0.0, -G],
        }
    }
}

/// Why [`Simulation::set_dynamics`] or [`Simulation::place_observed`] refused a state.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StateCopyError {
    #[error("cannot copy the state of a {src} into a {dst}: different vehicles")]
    Vehicle { src: String, dst: String },
    #[error("cannot copy the state of a simulation of a different world (heightmap, soil grid or obstacles)")]
    World,
    #[error("an observed state with a value that is not finite")]
    NotFinite,
}

/// A vehicle driving in a world: the vehicle's parameters ([`VehicleParams`], fixed at build), the world it drives
/// in (shared, not copied), the obstacles' broad phase, gravity, the dynamic state ([`DynamicsState`], what a step
/// changes) and the step's scratch ([`StepScratch`]). The step (`step.rs`) is a function of these parts.
///
/// The world is an `Arc<World>` rather than a `&World`: a borrow would put a lifetime on `Simulation` and so on
/// [`crate::EpisodeRun`], which the Python SDK's environments and the gRPC service keep across calls (they need
/// `'static`); a shared world lets every simulation and clone of one world (MPPI-6's shadow and rollout models,
/// an environment's episodes) hold it without copying it ([`Simulation::new_shared`]). The soil grid (in the state)
/// reads its undeformed ground and the obstacle set its obstacles from the same `Arc`.
#[derive(Clone, Debug)]
pub struct Simulation {
    pub(super) params: VehicleParams,
    pub(super) world: Arc<World>,
    /// The world's obstacles and their broad phase, shared by clones (its near list is in the state).
    pub(super) obstacles: ObstacleSet,
    /// Gravity, world frame, m/s^2 (default `(0, 0, -G)`; tilted for tilt-table scenarios).
    pub(super) gravity: Vector3<f64>,
    pub(super) state: DynamicsState,
    pub(super) scratch: StepScratch,
}

/// Fixed physics step for a vehicle scale: 4 ms at full scale (Chrono: 5 ms), scaled by sqrt(scale) (Froude similitude keeps the
/// ratio of step to natural periods); chosen by the stability tests in `tests/physics_*.rs`.
pub fn default_dt(scale: f64) -> f64 {
    0.004 * scale.sqrt()
}
