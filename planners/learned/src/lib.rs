//! Learned mobility systems: end-to-end policies trained with PPO on training worlds (RL, MCL, ACL; `POLICY.md`
//! gives their layout) and hybrids that roll out a learned kinodynamic model (MPPI-6; `KINO.md`). [`features`] is
//! the one definition of what a policy observes, shared with training through the Python extension;
//! [`net::PolicyNet`] runs a weights file's actor; [`LearnedPlanner`] drives episodes with it; [`kino`] holds the
//! kinodynamic models' inputs, inference and planner; [`builtin`] the committed weights.

pub mod builtin;
pub mod features;
pub mod kino;
pub mod net;
mod nn;
pub mod planner;
pub mod weights;

pub use builtin::{LearnedError, LearnedNet, NAMES};
pub use net::{PolicyNet, WeightsError};
pub use planner::LearnedPlanner;
