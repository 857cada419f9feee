//! Learned mobility systems: end-to-end policies trained with PPO on training worlds (RL, MCL, ACL; `POLICY.md`
//! gives their layout). [`features`] is the one definition of what a policy observes, shared with training through
//! the Python extension; [`net::PolicyNet`] runs a weights file's actor; [`LearnedPlanner`] drives episodes with it;
//! [`builtin`] holds the committed weights.

pub mod builtin;
pub mod features;
pub mod net;
pub mod planner;
pub mod weights;

pub use builtin::{LearnedError, NAMES};
pub use net::{PolicyNet, WeightsError};
pub use planner::LearnedPlanner;
