//! Vehicles: the catalogue ([`spec`]) and the multibody model that simulates them ([`model`]).

pub mod model;
pub mod spec;

pub use model::{Simulation, StateCopyError, StepInfo};
pub use spec::{builtin_vehicles, vehicle_by_name, VehicleError, VehicleSpec};
