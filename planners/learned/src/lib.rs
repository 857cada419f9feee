//! Learned mobility systems: end-to-end policies trained with PPO on training worlds (RL, MCL, ACL; `POLICY.md`
//! gives their layout). [`features`] is the one definition of what a policy observes, shared with training through
//! the Python extension.

pub mod features;
