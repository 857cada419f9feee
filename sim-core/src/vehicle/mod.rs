//! Vehicles: the catalogue ([`spec`]) and the multibody model that simulates them ([`Simulation`]).
//!
//! The model: a 6-DoF chassis, one vertical (suspension) DOF and one spin DOF per wheel, multi-point wheel contact
//! on the heightfield, tyre friction, soil, chassis contact, obstacles, powertrain, steering and brakes, integrated
//! at a fixed step. Frames: the chassis frame is centred at the centre of mass, x forward, y left, z up. Wheel `k`
//! hangs from a hard point at `(x_axle, +-track/2, -com_height)` (the wheel centre at static ride height); its
//! compression `x` along the chassis up axis is measured from full droop, so the spring force is `spring * x` and
//! the static sag is `load / spring` (tested).
//!
//! Contacts, all penalty-based with damping:
//! - wheel-ground: 7 rim points (-60 .. 60 degrees) x 3 lateral offsets sample the bilinear heightfield; the
//!   deepest point gives the tyre deflection and a radial normal, so a wheel climbs a step and rolls over a ridge;
//! - tyre friction on rigid ground: `mu = min(tyre mu, patch mu)`; the rigid tyre is Coulomb friction regularised by
//!   a stiff bristle (it holds on slopes below `atan(mu)` with brakes), the handling tyre a Magic-Formula curve of
//!   the combined slip with a friction circle;
//! - soil: on deformable patches the wheel's force comes from [`crate::soil::SoilGrid`] instead;
//! - chassis-ground: points on the body box (bottom, edges, top) against the heightfield (high-centering,
//!   bottoming out, rollover);
//! - obstacles: body points and wheel spheres against rocks and trees ([`crate::collide`]).
//!
//! Modules: `action` (the controls and what the vehicle reports), `simulation` ([`Simulation`] and the named
//! constants) and its parts: `params` (the vehicle's parameters, fixed at build), `dynamics` (the dynamic state,
//! [`DynamicsState`], read and set whole), `scratch` (the step's buffers); `build` (construction and placing),
//! `access` (accessors), `step` (the step as a pipeline of phases that take what they read and write, listed
//! there), and one module per phase: `powertrain`, `contact`, `tyre`, `suspension`, `body`, `integrate`.

mod access;
mod action;
mod body;
mod build;
mod contact;
mod dynamics;
mod integrate;
mod params;
mod powertrain;
mod scratch;
mod simulation;
pub mod spec;
mod step;
mod suspension;
mod tyre;

pub use action::{Action, VehicleInfo, VehicleState};
pub use dynamics::DynamicsState;
pub use simulation::{
    default_dt, SimOptions, Simulation, StateCopyError, StepInfo, WheelReport, SETTLED_FOR,
    SETTLED_SPEED, SETTLE_MAX,
};
pub use spec::{builtin_vehicles, vehicle_by_name, VehicleError, VehicleSpec};
