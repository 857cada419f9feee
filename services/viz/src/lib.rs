//! Trajectory files and plots of simulated episodes.
