//! A world's files: [`WorldRecord`] to its spec (`NNN.json`) and 16-bit heightmap (`NNN.png`) and back, with the
//! spec's fields checked against their physical ranges on the way in ([`crate::check`]).

use super::{read, world_stem, PatchSpec, TaskSpec, WorldRecord, WorldSpec};
use crate::TasksError;
use sim_core::world::{Heightmap, Patch, Surface, Task, World, MAP_PX};
use std::path::{Path, PathBuf};

/// Quantises heights to 16 bits; returns (min, max, samples in PNG row order).
fn quantise(h: &Heightmap) -> (f64, f64, Vec<u16>) {
    let lo = h
        .heights
        .iter()
        .fold(f64::INFINITY, |a, &v| a.min(v as f64));
    let hi = h
        .heights
        .iter()
        .fold(f64::NEG_INFINITY, |a, &v| a.max(v as f64));
    let (lo, hi) = ((lo * 1e4).floor() / 1e4, (hi * 1e4).ceil() / 1e4);
    let span = (hi - lo).max(1e-9);
    let mut out = Vec::with_capacity(h.nx * h.ny);
    for row in 0..h.ny {
        let iy = h.ny - 1 - row;
        for ix in 0..h.nx {
            out.push((((h.at(ix, iy) - lo) / span) * 65535.0).round() as u16);
        }
    }
    (lo, hi, out)
}

impl WorldRecord {
    pub(super) fn to_spec(&self) -> (WorldSpec, Vec<u16>) {
        let w = &self.world;
        let (lo, hi, q) = quantise(&w.heightmap);
        let patches = w
            .patches
            .iter()
            .map(|p| PatchSpec {
                class: p.semantic,
                friction: match p.surface {
                    Surface::Rigid { friction } => Some(friction),
                    Surface::Deformable { .. } => None,
                },
            })
            .collect();
        let tasks = self
            .tasks
            .iter()
            .map(|t| TaskSpec {
                index: t.index,
                start: t.start,
                goal: t.goal,
                path: t.path.clone(),
            })
            .collect();
        let spec = WorldSpec {
            id: w.id,
            level: w.level,
            semantics: w.semantics,
            density: w.density,
            terrain: self.terrain,
            cell: w.heightmap.cell,
            height_min: lo,
            height_max: hi,
            patches,
            obstacles: w.obstacles.clone(),
            tasks,
        };
        (spec, q)
    }
}

pub(super) fn encode_png16(q: &[u16], w: u32, h: u32, path: &Path) -> Result<Vec<u8>, TasksError> {
    let img: image::ImageBuffer<image::Luma<u16>, Vec<u16>> =
        image::ImageBuffer::from_raw(w, h, q.to_vec()).expect("buffer size matches");
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png)
        .map_err(|e| TasksError::Image {
            path: path.into(),
            message: e.to_string(),
        })?;
    Ok(out.into_inner())
}

/// Reads `NNN.json` from a worlds directory and checks its fields and their physical ranges ([`crate::check`]).
pub(super) fn read_spec(worlds_dir: &Path, id: u32) -> Result<(WorldSpec, PathBuf), TasksError> {
    let json_path = worlds_dir.join(format!("{}.json", world_stem(id)));
    let spec: WorldSpec =
        serde_json::from_slice(&read(&json_path)?).map_err(|e| TasksError::Json {
            path: json_path.clone(),
            source: e,
        })?;
    if spec.id != id {
        return Err(TasksError::field(
            &json_path,
            "id",
            format!("{} does not match the file name ({id})", spec.id),
        ));
    }
    crate::check::world_spec(&spec, &json_path)?;
    Ok((spec, json_path))
}

/// Loads `NNN.json` + `NNN.png` from a worlds directory.
pub fn load_record(worlds_dir: &Path, id: u32) -> Result<WorldRecord, TasksError> {
    let (spec, json_path) = read_spec(worlds_dir, id)?;
    let png_path = worlds_dir.join(format!("{}.png", world_stem(id)));
    let bad = |field: &str, msg: String| TasksError::field(&json_path, field, msg);
    let mut patches = Vec::with_capacity(spec.patches.len());
    for (k, p) in spec.patches.iter().enumerate() {
        // Checked above: a rigid class has a friction in range, a deformable one none.
        let surface = match (p.class.soil(), p.friction) {
            (Some(soil), _) => Surface::Deformable { soil },
            (None, f) => Surface::Rigid {
                friction: f
                    .ok_or_else(|| bad(&format!("patches[{k}].friction"), "missing".into()))?,
            },
        };
        patches.push(Patch {
            semantic: p.class,
            surface,
        });
    }
    let heightmap = load_png16(&png_path, spec.height_min, spec.height_max, spec.cell)?;
    let mut tasks = Vec::with_capacity(spec.tasks.len());
    for t in &spec.tasks {
        tasks.push(Task {
            world_id: id,
            index: t.index,
            start: t.start,
            goal: t.goal,
            path: t.path.clone(),
        });
    }
    let world = World {
        id,
        scale: 1.0,
        level: spec.level,
        semantics: spec.semantics,
        density: spec.density,
        heightmap,
        patches,
        obstacles: spec.obstacles,
    };
    Ok(WorldRecord {
        world,
        tasks,
        terrain: spec.terrain,
    })
}

fn load_png16(path: &Path, lo: f64, hi: f64, cell: f64) -> Result<Heightmap, TasksError> {
    let bytes = read(path)?;
    let image_error = |e: image::ImageError| TasksError::Image {
        path: path.into(),
        message: e.to_string(),
    };
    // The size from the header first: a huge image is refused before it is decoded (a 12000 x 12000 one took
    // 548 MB and 1.3 s).
    let reader =
        || image::ImageReader::with_format(std::io::Cursor::new(&bytes), image::ImageFormat::Png);
    let (w, h) = reader().into_dimensions().map_err(image_error)?;
    if w as usize != MAP_PX || h as usize != MAP_PX {
        return Err(TasksError::Image {
            path: path.into(),
            message: format!("size {w} x {h}, expected {MAP_PX} x {MAP_PX}"),
        });
    }
    let img = reader().decode().map_err(image_error)?;
    let img = match img {
        image::DynamicImage::ImageLuma16(i) => i,
        other => {
            return Err(TasksError::Image {
                path: path.into(),
                message: format!("expected a 16-bit grayscale PNG, found {:?}", other.color()),
            })
        }
    };
    let (w, h) = (img.width() as usize, img.height() as usize);
    if w != MAP_PX || h != MAP_PX {
        return Err(TasksError::Image {
            path: path.into(),
            message: format!("size {w} x {h}, expected {MAP_PX} x {MAP_PX}"),
        });
    }
    let raw = img.into_raw();
    let mut heights = vec![0f32; w * h];
    for row in 0..h {
        let iy = h - 1 - row;
        for ix in 0..w {
            heights[iy * w + ix] = (lo + raw[row * w + ix] as f64 / 65535.0 * (hi - lo)) as f32;
        }
    }
    Ok(Heightmap {
        nx: w,
        ny: h,
        cell,
        heights,
    })
}
