//! The versioned on-disk format of a task set (documented in `tasks/FORMAT.md`).
//!
//! ```text
//! <dir>/manifest.json      format tag, task-set version (content hash), seed, generator, world list
//! <dir>/worlds/NNN.json    human-readable world spec: factors, height range, patches, obstacles, tasks
//! <dir>/worlds/NNN.png     16-bit grayscale heightmap, 129 x 129, row 0 = north edge (the release's BMP orientation)
//! ```
//! Heights are quantised to 16 bits over `[height_min, height_max]` of the world spec (a step of at most 0.25 mm for
//! 16 m of relief). The version is the first 16 hex digits of the SHA-256 over every world file (name and bytes, in
//! id order), so any change to any world gives a new version.

use crate::TasksError;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use sim_core::world::{
    ElevationLevel, Heightmap, Obstacle, ObstacleDensity, Patch, Semantic, SemanticsKind, Surface,
    Task, World, MAP_PX,
};
use std::path::{Path, PathBuf};

/// Format tag of this version of the format.
pub const FORMAT: &str = "vertibench-tasks/1";

/// `manifest.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub format: String,
    /// Content hash naming this task set.
    pub version: String,
    /// Master seed the set was generated from (absent for imported sets).
    pub seed: Option<u64>,
    /// How the heights were made, e.g. `swae:<weights sha256 prefix>` or `import:verti-bench`.
    pub generator: String,
    pub worlds: Vec<WorldEntry>,
}

/// One world in the manifest (enough to filter without loading heights).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldEntry {
    pub id: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// Terrain group: worlds of one group share heights and patches (absent: the world is its own group).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<u32>,
}

impl WorldEntry {
    /// The world's terrain group (its own id when the set has no groups).
    pub fn terrain(&self) -> u32 {
        self.terrain.unwrap_or(self.id)
    }
}

/// A patch in a world spec: class, and friction for rigid classes (soil comes from the class).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PatchSpec {
    pub class: Semantic,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub friction: Option<f64>,
}

/// A task in a world spec. Paths are full-scale world coordinates.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskSpec {
    pub index: u32,
    pub start: [f64; 2],
    pub goal: [f64; 2],
    pub path: Vec<[f64; 2]>,
}

/// `worlds/NNN.json`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WorldSpec {
    pub id: u32,
    pub level: ElevationLevel,
    pub semantics: SemanticsKind,
    pub density: ObstacleDensity,
    /// Terrain group (absent: the world is its own group).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub terrain: Option<u32>,
    /// Sample spacing at full scale, m.
    pub cell: f64,
    pub height_min: f64,
    pub height_max: f64,
    /// 16 x 16 patches, row `pi` (along +y, south to north) major.
    pub patches: Vec<PatchSpec>,
    pub obstacles: Vec<Obstacle>,
    pub tasks: Vec<TaskSpec>,
}

/// A generated or imported world with its tasks, at full scale.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldRecord {
    pub world: World,
    pub tasks: Vec<Task>,
    /// Terrain group ([`crate::design`]); `None` when the world is its own group (imported worlds).
    pub terrain: Option<u32>,
}

/// A loaded task set.
#[derive(Clone, Debug)]
pub struct TaskSet {
    pub dir: PathBuf,
    pub manifest: Manifest,
}

fn read(path: &Path) -> Result<Vec<u8>, TasksError> {
    std::fs::read(path).map_err(|e| TasksError::io(path, e))
}

fn world_stem(id: u32) -> String {
    format!("{id:03}")
}

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
    fn to_spec(&self) -> (WorldSpec, Vec<u16>) {
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

/// Adds one world file (its name and bytes) to the task-set version's hash.
fn hash_file(hasher: &mut Sha256, path: &Path, bytes: &[u8]) {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    hasher.update(name.as_bytes());
    hasher.update(bytes);
}

/// The version: the first 16 hex digits of the hash.
fn version_of(hasher: Sha256) -> String {
    hasher
        .finalize()
        .iter()
        .take(8)
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// The version of the world files a manifest lists, from their content (as [`save`] computed it).
pub fn content_version(dir: &Path, manifest: &Manifest) -> Result<String, TasksError> {
    let worlds_dir = dir.join("worlds");
    let mut hasher = Sha256::new();
    for w in &manifest.worlds {
        for ext in ["json", "png"] {
            let path = worlds_dir.join(format!("{}.{ext}", world_stem(w.id)));
            hash_file(&mut hasher, &path, &read(&path)?);
        }
    }
    Ok(version_of(hasher))
}

/// Writes a task set to `dir` (replacing its world files) and returns its manifest.
pub fn save(
    dir: &Path,
    seed: Option<u64>,
    generator: &str,
    records: &[WorldRecord],
) -> Result<Manifest, TasksError> {
    let worlds_dir = dir.join("worlds");
    std::fs::create_dir_all(&worlds_dir).map_err(|e| TasksError::io(&worlds_dir, e))?;
    let mut hasher = Sha256::new();
    let mut entries = Vec::new();
    for r in records {
        let (spec, q) = r.to_spec();
        let json_path = worlds_dir.join(format!("{}.json", world_stem(spec.id)));
        let png_path = worlds_dir.join(format!("{}.png", world_stem(spec.id)));
        let value = serde_json::to_value(&spec).map_err(|e| TasksError::Json {
            path: json_path.clone(),
            source: e,
        })?;
        let json = one_item_per_line(&value).into_bytes();
        let png = encode_png16(
            &q,
            r.world.heightmap.nx as u32,
            r.world.heightmap.ny as u32,
            &png_path,
        )?;
        for (path, bytes) in [(&json_path, &json), (&png_path, &png)] {
            hash_file(&mut hasher, path, bytes);
            std::fs::write(path, bytes).map_err(|e| TasksError::io(path, e))?;
        }
        entries.push(WorldEntry {
            id: spec.id,
            level: spec.level,
            semantics: spec.semantics,
            density: spec.density,
            terrain: spec.terrain,
        });
    }
    let version = version_of(hasher);
    let manifest = Manifest {
        format: FORMAT.into(),
        version,
        seed,
        generator: generator.into(),
        worlds: entries,
    };
    let path = dir.join("manifest.json");
    let mut bytes = serde_json::to_vec_pretty(&manifest).map_err(|e| TasksError::Json {
        path: path.clone(),
        source: e,
    })?;
    bytes.push(b'\n');
    std::fs::write(&path, bytes).map_err(|e| TasksError::io(&path, e))?;
    Ok(manifest)
}

/// JSON with one top-level field per line and one array item per line (each item compact): readable and small.
fn one_item_per_line(value: &serde_json::Value) -> String {
    let serde_json::Value::Object(map) = value else {
        return format!("{value}\n");
    };
    let mut out = String::from("{\n");
    for (k, (key, v)) in map.iter().enumerate() {
        out += &format!("  {}: ", serde_json::Value::String(key.clone()));
        match v {
            serde_json::Value::Array(items) if !items.is_empty() => {
                out += "[\n";
                for (i, item) in items.iter().enumerate() {
                    out += &format!("    {item}{}\n", if i + 1 < items.len() { "," } else { "" });
                }
                out += "  ]";
            }
            other => out += &other.to_string(),
        }
        out += if k + 1 < map.len() { ",\n" } else { "\n" };
    }
    out + "}\n"
}

fn encode_png16(q: &[u16], w: u32, h: u32, path: &Path) -> Result<Vec<u8>, TasksError> {
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

impl TaskSet {
    /// The committed task set of this repository.
    pub fn default_dir() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data")
            .join("v4")
    }

    /// Opens the committed task set ([`TaskSet::default_dir`]).
    pub fn committed() -> Result<TaskSet, TasksError> {
        Self::load(&Self::default_dir())
    }

    /// Opens a task set directory: reads and validates the manifest, and recomputes the version from the world
    /// files, refusing a set whose files do not hash to the version its manifest claims (results carry the
    /// version, so it must say what they were computed on), and checks every world file's numbers against their
    /// physical ranges ([`crate::check`]).
    pub fn load(dir: &Path) -> Result<TaskSet, TasksError> {
        let path = dir.join("manifest.json");
        let bytes = read(&path)?;
        let manifest: Manifest = serde_json::from_slice(&bytes).map_err(|e| TasksError::Json {
            path: path.clone(),
            source: e,
        })?;
        if manifest.format != FORMAT {
            return Err(TasksError::field(
                &path,
                "format",
                format!(
                    "unsupported format `{}`, expected `{FORMAT}`",
                    manifest.format
                ),
            ));
        }
        let mut ids: Vec<u32> = manifest.worlds.iter().map(|w| w.id).collect();
        ids.sort_unstable();
        if ids.windows(2).any(|w| w[0] == w[1]) {
            return Err(TasksError::field(&path, "worlds", "duplicate world id"));
        }
        let actual = content_version(dir, &manifest)?;
        if actual != manifest.version {
            return Err(TasksError::field(
                &path,
                "version",
                format!(
                    "the manifest says `{}` but the world files hash to `{actual}`: the task set was changed after \
                     it was written; restore its files or regenerate it (`vb tasks generate`)",
                    manifest.version
                ),
            ));
        }
        // Every world file's numbers in their physical ranges, so a bad set is refused when opened, not mid-run.
        for w in &manifest.worlds {
            read_spec(&dir.join("worlds"), w.id)?;
        }
        Ok(TaskSet {
            dir: dir.to_path_buf(),
            manifest,
        })
    }

    /// The task-set version (content hash).
    pub fn version(&self) -> &str {
        &self.manifest.version
    }

    pub fn world_ids(&self) -> Vec<u32> {
        self.manifest.worlds.iter().map(|w| w.id).collect()
    }

    /// Factors of a world without loading it.
    pub fn world_meta(&self, id: u32) -> Result<&WorldEntry, TasksError> {
        self.manifest
            .worlds
            .iter()
            .find(|w| w.id == id)
            .ok_or(TasksError::UnknownWorld(id))
    }

    /// Loads one world at full scale with its tasks.
    pub fn record(&self, id: u32) -> Result<WorldRecord, TasksError> {
        self.world_meta(id)?;
        load_record(&self.dir.join("worlds"), id)
    }

    /// A world instantiated at `scale` (1, 1/6, 1/10, ...).
    pub fn world(&self, id: u32, scale: f64) -> Result<World, TasksError> {
        check_scale(scale)?;
        Ok(self.record(id)?.world.scaled(scale))
    }

    /// The tasks of a world at `scale`.
    pub fn tasks(&self, world_id: u32, scale: f64) -> Result<Vec<Task>, TasksError> {
        check_scale(scale)?;
        Ok(self
            .record(world_id)?
            .tasks
            .iter()
            .map(|t| t.scaled(scale))
            .collect())
    }

    /// Every world record, in id order.
    pub fn records(&self) -> Result<Vec<WorldRecord>, TasksError> {
        self.world_ids()
            .into_iter()
            .map(|id| self.record(id))
            .collect()
    }
}

fn check_scale(scale: f64) -> Result<(), TasksError> {
    if scale.is_finite() && scale > 0.0 && scale <= 10.0 {
        Ok(())
    } else {
        Err(TasksError::Param {
            field: "scale".into(),
            message: format!("{scale} is not in (0, 10]"),
        })
    }
}

/// Reads `NNN.json` from a worlds directory and checks its fields and their physical ranges ([`crate::check`]).
fn read_spec(worlds_dir: &Path, id: u32) -> Result<(WorldSpec, PathBuf), TasksError> {
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
    let img = image::load_from_memory_with_format(&read(path)?, image::ImageFormat::Png).map_err(
        |e| TasksError::Image {
            path: path.into(),
            message: e.to_string(),
        },
    )?;
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
