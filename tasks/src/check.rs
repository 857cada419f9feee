//! Physical ranges of a world file's numbers (`tasks/FORMAT.md`), checked whenever a task set is opened
//! ([`crate::TaskSet::load`]) and a world is loaded: every number must be finite and in a range a real world can
//! have, so a hand-edited set (heights of 1e300, negative sizes, NaN) is refused with the file and field instead of
//! reaching the simulator and being charged to a planner.

use crate::format::WorldSpec;
use crate::TasksError;
use sim_core::world::{MAP_PX, PATCHES};
use std::path::Path;

/// Sample spacing at full scale, m.
pub const CELL_RANGE: (f64, f64) = (0.01, 10.0);
/// Largest height magnitude (heights, obstacle bases), m: deeper than any sea, higher than any mountain.
pub const MAX_ABS_HEIGHT: f64 = 10_000.0;
/// Rigid patch friction coefficient.
pub const FRICTION_RANGE: (f64, f64) = (0.0, 2.0);
/// Largest obstacle half size, m (a 100 m boulder).
pub const MAX_HALF_EXTENT: f64 = 50.0;
/// Largest obstacle yaw magnitude, rad (a few turns; written in [0, 2 pi)).
pub const MAX_ABS_YAW: f64 = 4.0 * std::f64::consts::TAU;
/// Most points of a task's global path.
pub const MAX_PATH_POINTS: usize = 100_000;

/// Checks every number of a world file against its physical range; the error names the file and the field.
pub fn world_spec(spec: &WorldSpec, path: &Path) -> Result<(), TasksError> {
    grid(spec, path)?;
    patches(spec, path)?;
    // The map's half extents, as `Heightmap::contains` sees them once the PNG (MAP_PX square) is loaded.
    let half = (MAP_PX - 1) as f64 * spec.cell * 0.5;
    obstacles(spec, path, half)?;
    tasks(spec, path, half)
}

/// The sample spacing and the height range.
fn grid(spec: &WorldSpec, path: &Path) -> Result<(), TasksError> {
    let bad = |field: String, msg: String| Err(TasksError::field(path, field, msg));
    let (lo, hi) = CELL_RANGE;
    if !(spec.cell.is_finite() && (lo..=hi).contains(&spec.cell)) {
        return bad(
            "cell".into(),
            format!("{} m is not a sample spacing in [{lo}, {hi}] m", spec.cell),
        );
    }
    for (field, h) in [
        ("height_min", spec.height_min),
        ("height_max", spec.height_max),
    ] {
        if !(h.is_finite() && h.abs() <= MAX_ABS_HEIGHT) {
            return bad(
                field.into(),
                format!("{h} m is not a height in [-{MAX_ABS_HEIGHT}, {MAX_ABS_HEIGHT}] m"),
            );
        }
    }
    if spec.height_max < spec.height_min {
        return bad(
            "height_max".into(),
            format!(
                "{} m is below height_min ({} m): the height range is empty",
                spec.height_max, spec.height_min
            ),
        );
    }
    Ok(())
}

/// 16 x 16 patches, a friction for each rigid class and none for a deformable one.
fn patches(spec: &WorldSpec, path: &Path) -> Result<(), TasksError> {
    let bad = |field: String, msg: String| Err(TasksError::field(path, field, msg));
    if spec.patches.len() != PATCHES * PATCHES {
        return bad(
            "patches".into(),
            format!(
                "{} patches, expected {}",
                spec.patches.len(),
                PATCHES * PATCHES
            ),
        );
    }
    let (flo, fhi) = FRICTION_RANGE;
    for (k, p) in spec.patches.iter().enumerate() {
        let field = format!("patches[{k}].friction");
        match (p.class.soil(), p.friction) {
            (None, Some(f)) if !(f.is_finite() && (flo..=fhi).contains(&f)) => {
                return bad(field, format!("{f} is not in [{flo}, {fhi}]"))
            }
            (None, None) => {
                return bad(
                    field,
                    format!("missing for rigid class {}", p.class.as_str()),
                )
            }
            (Some(_), Some(_)) => {
                return bad(
                    field,
                    format!("given for deformable class {}", p.class.as_str()),
                )
            }
            _ => {}
        }
    }
    Ok(())
}

/// Obstacles on the map (half extents `half`), at a height, with a yaw and a size.
fn obstacles(spec: &WorldSpec, path: &Path, half: f64) -> Result<(), TasksError> {
    let bad = |field: String, msg: String| Err(TasksError::field(path, field, msg));
    for (k, o) in spec.obstacles.iter().enumerate() {
        let field = |name: &str| format!("obstacles[{k}].{name}");
        for (name, v) in [("x", o.x), ("y", o.y)] {
            if !(v.is_finite() && v.abs() <= half) {
                return bad(
                    field(name),
                    format!("{v} m is outside the map ([-{half}, {half}] m)"),
                );
            }
        }
        if !(o.z.is_finite() && o.z.abs() <= MAX_ABS_HEIGHT) {
            return bad(
                field("z"),
                format!(
                    "{} m is not a height in [-{MAX_ABS_HEIGHT}, {MAX_ABS_HEIGHT}] m",
                    o.z
                ),
            );
        }
        if !(o.yaw.is_finite() && o.yaw.abs() <= MAX_ABS_YAW) {
            return bad(
                field("yaw"),
                format!("{} rad is not an angle in [-8 pi, 8 pi]", o.yaw),
            );
        }
        for (i, h) in o.half_extents.iter().enumerate() {
            if !(h.is_finite() && *h > 0.0 && *h <= MAX_HALF_EXTENT) {
                return bad(
                    field(&format!("half_extents[{i}]")),
                    format!("{h} m is not a half size in (0, {MAX_HALF_EXTENT}] m"),
                );
            }
        }
    }
    Ok(())
}

/// Starts, goals and paths on the map (half extents `half`).
fn tasks(spec: &WorldSpec, path: &Path, half: f64) -> Result<(), TasksError> {
    let bad = |field: String, msg: String| Err(TasksError::field(path, field, msg));
    let inside = |x: f64, y: f64| x.abs() <= half && y.abs() <= half;
    for (k, t) in spec.tasks.iter().enumerate() {
        let field = |name: &str| format!("tasks[{k}].{name}");
        for (name, p) in [("start", t.start), ("goal", t.goal)] {
            if !inside(p[0], p[1]) {
                return bad(
                    field(name),
                    format!(
                        "[{}, {}] is not a point of the map ([-{half}, {half}] m each)",
                        p[0], p[1]
                    ),
                );
            }
        }
        if t.path.len() < 2 || t.path.len() > MAX_PATH_POINTS {
            return bad(
                field("path"),
                format!(
                    "{} points: a path needs 2 to {MAX_PATH_POINTS}",
                    t.path.len()
                ),
            );
        }
        if let Some((i, p)) = t.path.iter().enumerate().find(|(_, p)| !inside(p[0], p[1])) {
            return bad(
                field(&format!("path[{i}]")),
                format!(
                    "[{}, {}] is not a point of the map ([-{half}, {half}] m each)",
                    p[0], p[1]
                ),
            );
        }
    }
    Ok(())
}
