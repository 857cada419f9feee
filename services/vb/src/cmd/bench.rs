//! `vb bench sim`: real-time factors of every vehicle on rigid and soft ground.

use clap::Subcommand;
use std::path::PathBuf;

#[derive(Subcommand)]
pub enum BenchCmd {
    /// Simulated seconds per wall-clock second, per vehicle, on a rigid and a deformable world (one core).
    Sim {
        /// Simulated seconds per run.
        #[arg(long, default_value_t = 30.0)]
        seconds: f64,
        #[arg(long)]
        task_dir: Option<PathBuf>,
    },
}

pub fn run(cmd: BenchCmd) -> anyhow::Result<()> {
    match cmd {
        BenchCmd::Sim { seconds, task_dir } => {
            anyhow::ensure!(
                seconds.is_finite() && seconds > 0.0,
                "--seconds must be positive"
            );
            let set = tasks::TaskSet::load(&task_dir.unwrap_or_else(tasks::TaskSet::default_dir))?;
            // The first rigid and the first deformable world of the set.
            let pick = |kind: sim_core::world::SemanticsKind| -> anyhow::Result<u32> {
                set.world_ids()
                    .into_iter()
                    .find(|id| {
                        set.world_meta(*id)
                            .map(|m| m.semantics == kind)
                            .unwrap_or(false)
                    })
                    .ok_or_else(|| anyhow::anyhow!("no {} world in the task set", kind.as_str()))
            };
            let rigid = pick(sim_core::world::SemanticsKind::Rigid)?;
            let soft = pick(sim_core::world::SemanticsKind::Deformable)?;
            println!("vehicle       ground      world  steps/s     us/step  real-time factor");
            for spec in sim_core::vehicle::builtin_vehicles() {
                for (label, id) in [("rigid", rigid), ("deformable", soft)] {
                    let w = set.world(id, spec.scale)?;
                    let t = &set.tasks(id, spec.scale)?[0];
                    let cfg = sim_core::episode::EpisodeConfig {
                        max_time: seconds,
                        goal_radius: 0.0,
                        stuck: sim_core::episode::StuckRule::Displacement {
                            distance: 0.0,
                            window: seconds + 1.0,
                        },
                        ..Default::default()
                    };
                    let mut p = sim_core::control::PurePursuit::new();
                    let t0 = std::time::Instant::now();
                    let r = sim_core::run_episode(&w, t, &spec, &mut p, &cfg);
                    let wall = t0.elapsed().as_secs_f64();
                    println!(
                        "{:<13} {:<11} {:>5} {:>8.0} {:>11.2} {:>10.0}x   ({} after {:.1} s)",
                        spec.name,
                        label,
                        id,
                        r.metrics.steps as f64 / wall,
                        wall * 1e6 / r.metrics.steps as f64,
                        r.metrics.time / wall,
                        r.outcome.as_str(),
                        r.metrics.time
                    );
                }
            }
        }
    }
    Ok(())
}
