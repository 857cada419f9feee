//! Baseline mobility systems: PID, elevation heuristics, MPPI, MPPI-6.
