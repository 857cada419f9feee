//! The vehicle's parameters ([`VehicleParams`]): everything the step reads about the vehicle and its world that does
//! not change once the simulation is built (the spec, the step, masses and inertia, contact stiffnesses, each
//! wheel's constants, the spin groups and clutches, the body's contact points, the terrain's block maxima).

use super::powertrain::Clutch;
use super::simulation::OBSTACLE_NEAR_SLACK;
use crate::vehicle::spec::VehicleSpec;
use nalgebra::{Matrix3, Vector3};

/// One wheel's (or track contact's) constants: where it hangs, how it is sprung, steered and driven.
#[derive(Clone, Debug)]
pub(super) struct WheelParams {
    /// Hard point (wheel centre at static ride height) in the chassis frame.
    pub(super) hard: Vector3<f64>,
    /// +1 left, -1 right.
    pub(super) side: f64,
    pub(super) steer_factor: f64,
    pub(super) steered: bool,
    /// Whether the powertrain drives this contact (all contacts of a tracked vehicle are driven).
    pub(super) driven: bool,
    pub(super) group: usize,
    pub(super) spring: f64,
    pub(super) damper: f64,
    pub(super) travel: f64,
    /// Compression at static ride height (spring preload reference), m.
    pub(super) static_compression: f64,
}

impl WheelParams {
    /// The wheel centre in the chassis frame at suspension `compression`: the hard point moved along the chassis up
    /// axis by the compression relative to the static one.
    pub(super) fn centre_offset(&self, compression: f64) -> Vector3<f64> {
        self.hard
            + Vector3::new(
                0.0,
                0.0,
                compression - self.static_compression.min(self.travel),
            )
    }
}

/// The vehicle's parameters, fixed when the simulation is built (see the module docs); the step reads them and
/// never writes them. Gravity is not among them: it is an argument of the step (a tilt table turns it, settling
/// ramps it up).
#[derive(Clone, Debug)]
pub(super) struct VehicleParams {
    pub(super) spec: VehicleSpec,
    /// Physics step, s.
    pub(super) dt: f64,
    /// Sprung mass (chassis), kg.
    pub(super) mass: f64,
    /// Total mass (chassis and wheels), kg.
    pub(super) total_mass: f64,
    pub(super) inertia: Matrix3<f64>,
    pub(super) inertia_inv: Matrix3<f64>,
    pub(super) unsprung: f64,
    pub(super) radius: f64,
    pub(super) width: f64,
    pub(super) wheel_inertia: f64,
    pub(super) tyre_mu: f64,
    pub(super) bristle_k: f64,
    pub(super) bristle_c: f64,
    pub(super) tyre_k: f64,
    pub(super) tyre_c: f64,
    pub(super) body_points: Vec<Vector3<f64>>,
    pub(super) body_k: f64,
    pub(super) body_c: f64,
    pub(super) obstacle_k: f64,
    pub(super) wheels: Vec<WheelParams>,
    pub(super) groups: usize,
    /// Total spin inertia of each group.
    pub(super) group_inertia: Vec<f64>,
    /// The locking clutches of a clutched driveline.
    pub(super) clutches: Vec<Clutch>,
    /// Highest terrain (plus one cell of slack) over 4 x 4-sample blocks: a body point above it cannot touch.
    pub(super) block_max: Vec<f64>,
    pub(super) blocks_x: usize,
}

impl VehicleParams {
    /// Radius of the obstacle near list around the chassis.
    pub(super) fn reach(&self) -> f64 {
        0.5 * self.spec.chassis.size[0].hypot(self.spec.chassis.size[1])
            + self.radius
            + OBSTACLE_NEAR_SLACK * self.spec.scale
    }
}
