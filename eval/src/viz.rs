//! Trajectory files and plots of single simulated episodes (`vb sim run`): `trajectory.csv` and a PNG with the path drawn over the map
//! (left) and roll, pitch and speed over time (right).

use image::{Rgb, RgbImage};
use sim_core::episode::{EpisodeResult, TrajectorySample};
use sim_core::world::{Task, World};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum VizError {
    #[error("{path}: {message}")]
    Write { path: String, message: String },
}

fn world_px(world: &World, x: f64, y: f64, ppm: f64) -> (f64, f64) {
    let (fx, fy) = world.heightmap.grid_coords(x, y);
    (
        (fx + 0.5) * ppm,
        ((world.heightmap.ny - 1) as f64 - fy + 0.5) * ppm,
    )
}

/// A signal plotted over time.
type Signal = fn(&TrajectorySample) -> f64;

/// Picture of an episode: map with global path (red) and driven path (yellow), then time series.
pub fn episode_plot(world: &World, task: &Task, result: &EpisodeResult) -> RgbImage {
    let record = tasks::format::WorldRecord {
        world: world.clone(),
        tasks: vec![task.clone()],
        terrain: None,
    };
    let ppm = 4u32;
    let map = tasks::render::render_world(&record, ppm);
    let (mw, mh) = (map.width(), map.height());
    let plot_w = 600u32;
    let mut img = RgbImage::from_pixel(mw + plot_w, mh, Rgb([255, 255, 255]));
    image::imageops::overlay(&mut img, &map, 0, 0);
    let traj = &result.trajectory;
    for w in traj.windows(2) {
        let a = world_px(world, w[0].x, w[0].y, ppm as f64);
        let b = world_px(world, w[1].x, w[1].y, ppm as f64);
        tasks::render::line(&mut img, a, b, 3.0, [250, 220, 0]);
    }
    // Time series: three stacked panels (roll deg, pitch deg, speed m/s).
    let t_max = traj.last().map_or(1.0, |s| s.time).max(1e-6);
    let panel_h = mh / 3;
    let series: [(Signal, [u8; 3]); 3] = [
        (|s| s.roll.to_degrees(), [200, 40, 40]),
        (|s| s.pitch.to_degrees(), [40, 90, 200]),
        (|s| s.speed, [30, 150, 60]),
    ];
    for (k, (f, colour)) in series.iter().enumerate() {
        let top = k as u32 * panel_h;
        let lo = traj.iter().map(f).fold(f64::INFINITY, f64::min).min(0.0);
        let hi = traj
            .iter()
            .map(f)
            .fold(f64::NEG_INFINITY, f64::max)
            .max(lo + 1e-3);
        let to_px = |t: f64, v: f64| {
            let x = mw as f64 + 20.0 + (plot_w as f64 - 40.0) * t / t_max;
            let y = top as f64 + 10.0 + (panel_h as f64 - 20.0) * (1.0 - (v - lo) / (hi - lo));
            (x, y)
        };
        // Axis and zero line.
        tasks::render::line(
            &mut img,
            to_px(0.0, lo),
            to_px(t_max, lo),
            1.0,
            [120, 120, 120],
        );
        tasks::render::line(
            &mut img,
            to_px(0.0, 0.0),
            to_px(t_max, 0.0),
            1.0,
            [200, 200, 200],
        );
        for w in traj.windows(2) {
            tasks::render::line(
                &mut img,
                to_px(w[0].time, f(&w[0])),
                to_px(w[1].time, f(&w[1])),
                2.0,
                *colour,
            );
        }
    }
    img
}

/// Writes `trajectory.csv`, `episode.png` and `result.json` into `dir`.
pub fn write_episode(
    dir: &Path,
    world: &World,
    task: &Task,
    result: &EpisodeResult,
    result_json: &str,
) -> Result<(), VizError> {
    let err = |p: &Path, e: &dyn std::fmt::Display| VizError::Write {
        path: p.display().to_string(),
        message: e.to_string(),
    };
    std::fs::create_dir_all(dir).map_err(|e| err(dir, &e))?;
    let csv = dir.join("trajectory.csv");
    std::fs::write(&csv, sim_core::trajectory::to_csv(&result.trajectory))
        .map_err(|e| err(&csv, &e))?;
    let png = dir.join("episode.png");
    episode_plot(world, task, result)
        .save(&png)
        .map_err(|e| err(&png, &e))?;
    let json = dir.join("result.json");
    std::fs::write(&json, result_json).map_err(|e| err(&json, &e))?;
    Ok(())
}
