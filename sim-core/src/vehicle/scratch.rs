//! The step's scratch ([`StepScratch`]): buffers one step fills and reads again, preallocated at build so the step
//! allocates nothing. Nothing in it carries over to the next step, except that the last step's contacts and ground
//! forces stay readable for reports ([`Simulation::wheels`](super::Simulation::wheels)).

use nalgebra::Vector3;

/// A wheel's contact with the ground in this step (phase 4, `contact`), read by the later phases.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct WheelContact {
    pub(super) active: bool,
    pub(super) soil: bool,
    pub(super) point: Vector3<f64>,
    pub(super) normal: Vector3<f64>,
    /// Normal force magnitude (tyre deflection force), N.
    pub(super) load: f64,
    /// Stiffness and damping of the contact force along `normal` with respect to the wheel centre's motion along
    /// it (tyre deflection or soil), N/m and N s/m: the Jacobian of the wheel's implicit vertical update.
    pub(super) k_normal: f64,
    pub(super) c_normal: f64,
    /// Sinkage below the undeformed soil surface (soil) or tyre deflection (rigid ground), m.
    pub(super) sinkage: f64,
    pub(super) mu: f64,
    pub(super) tx: Vector3<f64>,
    pub(super) ty: Vector3<f64>,
    /// Force on the wheel from the ground (soil: complete), world.
    pub(super) soil_force: Vector3<f64>,
    /// The soil's traction stiffness ([`crate::soil::SoilContact::traction_stiffness`]), N s/m.
    pub(super) soil_stiffness: f64,
    /// The soil's torque on the wheel about its axle (positive along the spin), N m, and its Jacobians
    /// ([`crate::soil::SoilContact::spin_stiffness`], [`crate::soil::SoilContact::spin_force`],
    /// [`crate::soil::SoilContact::spin_lift`]).
    pub(super) soil_torque: f64,
    pub(super) spin_stiffness: f64,
    pub(super) spin_force: f64,
    pub(super) spin_lift: f64,
    /// The soil's full moment about the wheel's centre, N m (world).
    pub(super) soil_moment: Vector3<f64>,
    /// The soil's Mohr-Coulomb shear capacity over the contact, N.
    pub(super) shear_capacity: f64,
    pub(super) r_eff: f64,
}

/// Per spin group sums of one step (phases 3 to 6): drive torque, the ground's torque and effective inertia for
/// the implicit spin update, momentum, brake torque, and the spin before clutches and brakes.
#[derive(Clone, Debug)]
pub(super) struct GroupSums {
    pub(super) torque: Vec<f64>,
    pub(super) num: Vec<f64>,
    pub(super) den: Vec<f64>,
    pub(super) spin: Vec<f64>,
    pub(super) brake: Vec<f64>,
    pub(super) free: Vec<f64>,
}

/// The step's scratch (see the module docs).
#[derive(Clone, Debug)]
pub(super) struct StepScratch {
    pub(super) groups: GroupSums,
    /// The clutches' torques in this step.
    pub(super) clutch_torque: Vec<f64>,
    /// Each wheel's contact in this step.
    pub(super) contacts: Vec<WheelContact>,
    /// Ground force on each wheel in the last step, world frame (for reports).
    pub(super) ground_forces: Vec<Vector3<f64>>,
    /// Each wheel's spin before this step's spin update.
    pub(super) spin_before: Vec<f64>,
}

impl StepScratch {
    /// Buffers for `groups` spin groups, `clutches` clutches and `wheels` wheels.
    pub(super) fn new(groups: usize, clutches: usize, wheels: usize) -> StepScratch {
        StepScratch {
            groups: GroupSums {
                torque: vec![0.0; groups],
                num: vec![0.0; groups],
                den: vec![0.0; groups],
                spin: vec![0.0; groups],
                brake: vec![0.0; groups],
                free: vec![0.0; groups],
            },
            clutch_torque: vec![0.0; clutches],
            contacts: vec![WheelContact::default(); wheels],
            ground_forces: vec![Vector3::zeros(); wheels],
            spin_before: vec![0.0; wheels],
        }
    }
}
