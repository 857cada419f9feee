//! Writing a task set ([`save`]) and its version: the first 16 hex digits of the SHA-256 over every world file's
//! name and bytes, in id order ([`content_version`] recomputes it from the files).

use super::world_file::encode_png16;
use super::{read, world_stem, Manifest, WorldEntry, WorldRecord, FORMAT};
use crate::TasksError;
use sha2::{Digest, Sha256};
use std::path::Path;

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
