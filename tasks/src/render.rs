//! PNG pictures of worlds: hill-shaded elevation tinted by semantic class, obstacles, start/goal points and global
//! paths; and a contact sheet of many worlds. North is up.

use crate::format::WorldRecord;
use image::{Rgb, RgbImage};
use sim_core::world::{Heightmap, ObstacleKind, Semantic, World};

/// Display colour of a semantic class.
pub fn class_colour(s: Semantic) -> [u8; 3] {
    match s {
        Semantic::Clay => [178, 102, 68],
        Semantic::Concrete => [170, 170, 170],
        Semantic::Dirt => [139, 105, 60],
        Semantic::Grass => [96, 160, 72],
        Semantic::Gravel => [150, 140, 120],
        Semantic::Rock => [110, 105, 100],
        Semantic::Wood => [160, 120, 70],
        Semantic::Mud => [90, 70, 50],
        Semantic::Sand => [220, 200, 140],
        Semantic::Snow => [235, 240, 250],
    }
}

/// Hill shade in [0, 1] at every sample (light from the north-west, 45 degrees up), row-major by `iy`.
pub fn hillshade_values(h: &Heightmap) -> Vec<f64> {
    let (az, alt) = (315f64.to_radians(), 45f64.to_radians());
    let light = [alt.cos() * az.sin(), alt.cos() * az.cos(), alt.sin()];
    let mut out = vec![0.0; h.nx * h.ny];
    for iy in 0..h.ny {
        for ix in 0..h.nx {
            let x0 = h.at(ix.saturating_sub(1), iy);
            let x1 = h.at((ix + 1).min(h.nx - 1), iy);
            let y0 = h.at(ix, iy.saturating_sub(1));
            let y1 = h.at(ix, (iy + 1).min(h.ny - 1));
            let (gx, gy) = ((x1 - x0) / (2.0 * h.cell), (y1 - y0) / (2.0 * h.cell));
            let n = [-gx, -gy, 1.0];
            let len = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
            let shade = (n[0] * light[0] + n[1] * light[1] + n[2] * light[2]) / len;
            out[iy * h.nx + ix] = shade.clamp(0.0, 1.0);
        }
    }
    out
}

/// Grey hill-shaded picture of a heightmap, one pixel per sample, north up.
pub fn hillshade(h: &Heightmap) -> RgbImage {
    let shade = hillshade_values(h);
    RgbImage::from_fn(h.nx as u32, h.ny as u32, |px, py| {
        let iy = h.ny - 1 - py as usize;
        let v = (shade[iy * h.nx + px as usize] * 255.0) as u8;
        Rgb([v, v, v])
    })
}

/// Maps a world point to pixel coordinates of a picture with `ppm` pixels per sample.
fn to_px(w: &World, x: f64, y: f64, ppm: f64) -> (f64, f64) {
    let (fx, fy) = w.heightmap.grid_coords(x, y);
    (
        (fx + 0.5) * ppm,
        ((w.heightmap.ny - 1) as f64 - fy + 0.5) * ppm,
    )
}

fn put(img: &mut RgbImage, x: i64, y: i64, c: [u8; 3]) {
    if x >= 0 && y >= 0 && (x as u32) < img.width() && (y as u32) < img.height() {
        img.put_pixel(x as u32, y as u32, Rgb(c));
    }
}

fn disc(img: &mut RgbImage, cx: f64, cy: f64, r: f64, c: [u8; 3]) {
    let ri = r.ceil() as i64;
    for dy in -ri..=ri {
        for dx in -ri..=ri {
            if ((dx * dx + dy * dy) as f64) <= r * r {
                put(img, cx as i64 + dx, cy as i64 + dy, c);
            }
        }
    }
}

/// Draws a line segment (DDA), `width` pixels thick.
pub fn line(img: &mut RgbImage, a: (f64, f64), b: (f64, f64), width: f64, c: [u8; 3]) {
    let steps = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
    for k in 0..=steps {
        let t = k as f64 / steps as f64;
        disc(
            img,
            a.0 + (b.0 - a.0) * t,
            a.1 + (b.1 - a.1) * t,
            width / 2.0,
            c,
        );
    }
}

/// Picture of a world with `ppm` pixels per sample: shaded semantics, obstacles, tasks and paths.
pub fn render_world(record: &WorldRecord, ppm: u32) -> RgbImage {
    let w = &record.world;
    let h = &w.heightmap;
    let shade = hillshade_values(h);
    let mut img = RgbImage::from_fn(h.nx as u32 * ppm, h.ny as u32 * ppm, |px, py| {
        let ix = (px / ppm) as usize;
        let iy = h.ny - 1 - (py / ppm) as usize;
        let (x, y) = h.sample_position(ix, iy);
        let base = class_colour(w.patch_at(x, y).semantic);
        let s = 0.35 + 0.65 * shade[iy * h.nx + ix];
        Rgb(base.map(|c| (c as f64 * s).min(255.0) as u8))
    });
    let ppm_f = ppm as f64;
    for o in &w.obstacles {
        let colour = match o.kind {
            ObstacleKind::Rock => [40, 40, 40],
            ObstacleKind::Tree => [20, 90, 20],
        };
        let (cx, cy) = to_px(w, o.x, o.y, ppm_f);
        match o.kind {
            ObstacleKind::Tree => disc(
                &mut img,
                cx,
                cy,
                (o.half_extents[0] / h.cell * ppm_f).max(2.0),
                colour,
            ),
            ObstacleKind::Rock => {
                let (s, c) = o.yaw.sin_cos();
                let [a, b, _] = o.half_extents;
                let n = 24;
                for i in 0..=n {
                    for j in 0..=n {
                        let (u, v) = (
                            a * (2.0 * i as f64 / n as f64 - 1.0),
                            b * (2.0 * j as f64 / n as f64 - 1.0),
                        );
                        let (px, py) = to_px(w, o.x + c * u - s * v, o.y + s * u + c * v, ppm_f);
                        disc(&mut img, px, py, ppm_f * 0.5, colour);
                    }
                }
            }
        }
    }
    for t in &record.tasks {
        for seg in t.path.windows(2) {
            let a = to_px(w, seg[0][0], seg[0][1], ppm_f);
            let b = to_px(w, seg[1][0], seg[1][1], ppm_f);
            line(&mut img, a, b, (ppm_f * 0.4).max(1.0), [220, 30, 30]);
        }
    }
    for t in &record.tasks {
        let (sx, sy) = to_px(w, t.start[0], t.start[1], ppm_f);
        let (gx, gy) = to_px(w, t.goal[0], t.goal[1], ppm_f);
        disc(&mut img, sx, sy, ppm_f * 1.2 + 1.0, [30, 200, 60]);
        disc(&mut img, gx, gy, ppm_f * 0.8 + 1.0, [30, 60, 220]);
    }
    img
}

/// Contact sheet: worlds in rows of `columns`, each at one pixel per sample with a 2-pixel gap.
pub fn contact_sheet(records: &[WorldRecord], columns: usize) -> RgbImage {
    let tile = records
        .first()
        .map(|r| r.world.heightmap.nx as u32)
        .unwrap_or(129)
        + 2;
    let columns = columns.max(1);
    let rows = records.len().div_ceil(columns).max(1);
    let mut sheet = RgbImage::from_pixel(
        tile * columns as u32,
        tile * rows as u32,
        Rgb([255, 255, 255]),
    );
    for (k, r) in records.iter().enumerate() {
        let img = render_world(r, 1);
        let (ox, oy) = (
            (k % columns) as u32 * tile + 1,
            (k / columns) as u32 * tile + 1,
        );
        image::imageops::overlay(&mut sheet, &img, ox as i64, oy as i64);
    }
    sheet
}

impl crate::TaskSet {
    /// World `id` as pages draw it ([`contracts::WorldPicture`]): its map without the tasks drawn in, as PNG at
    /// `ppm` pixels per sample, and its tasks' geometry (full scale).
    pub fn world_picture(
        &self,
        id: u32,
        ppm: u32,
    ) -> Result<contracts::WorldPicture, crate::TasksError> {
        let mut record = self.record(id)?;
        let tasks = std::mem::take(&mut record.tasks)
            .into_iter()
            .map(|t| contracts::TaskGeometry {
                start: t.start,
                goal: t.goal,
                path: t.path,
            })
            .collect();
        let mut png = Vec::new();
        render_world(&record, ppm)
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .map_err(|e| crate::TasksError::Param {
                field: "picture".into(),
                message: format!("encoding the map of world {id}: {e}"),
            })?;
        let h = &record.world.heightmap;
        Ok(contracts::WorldPicture {
            png,
            ppm,
            nx: h.nx,
            ny: h.ny,
            cell: h.cell,
            tasks,
        })
    }
}
