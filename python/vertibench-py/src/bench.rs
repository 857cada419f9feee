//! The raw simulator throughput that `python -m vertibench.bench` compares the environments with: the same
//! vehicles on the same tasks, stepped by `Simulation::step` alone (no episode rules, no observations, no Python).

use crate::source::Source;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use sim_core::episode::EpisodeConfig;
use sim_core::planner::Action;
use sim_core::runner::start_pose;
use sim_core::Simulation;
use std::path::PathBuf;
use std::time::Instant;

/// Steps `num_envs` simulations (on the first selected tasks, cycling) `steps` times each with `action`, in
/// parallel on `num_threads` threads; returns `(physics steps, seconds)` (building and settling excluded).
#[pyfunction]
#[pyo3(signature = (num_envs, steps, task_dir, tasks="all", action=(0.3, 0.5, 0.0), num_threads=None))]
pub fn raw_throughput(
    py: Python<'_>,
    num_envs: usize,
    steps: u64,
    task_dir: PathBuf,
    tasks: &str,
    action: (f64, f64, f64),
    num_threads: Option<usize>,
) -> PyResult<(u64, f64)> {
    let tasks = tasks.to_string();
    py.detach(|| {
        let src = Source::load(&task_dir, &tasks, "hmmwv", None, EpisodeConfig::default())?;
        let mut sims: Vec<Simulation> = (0..num_envs)
            .into_par_iter()
            .map(|i| {
                let (lw, t) = src.get(i % src.tasks.len());
                let (x, y, yaw) = start_pose(t);
                Simulation::new(&lw.world, &src.vehicle, x, y, yaw)
            })
            .collect();
        let a = Action {
            steering: action.0,
            throttle: action.1,
            brake: action.2,
        };
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(num_threads.unwrap_or(0))
            .build()
            .map_err(|e| e.to_string())?;
        let t0 = Instant::now();
        pool.install(|| {
            sims.par_iter_mut().for_each(|s| {
                for _ in 0..steps {
                    s.step(&a);
                }
            })
        });
        Ok((steps * num_envs as u64, t0.elapsed().as_secs_f64()))
    })
    .map_err(|e: String| PyValueError::new_err(e))
}
