//! Library side of `vb tasks ...`: each function does one subcommand's work and returns what to print.

use crate::format::{self, WorldRecord};
use crate::generate::{self, HeightSource};
use crate::{import, render, stats, TaskSet, TasksError};
use sim_core::world::SemanticsKind;
use std::path::Path;

/// Generates the whole task set into `out` and returns its manifest.
pub fn generate_set(
    out: &Path,
    seed: u64,
    source: &dyn HeightSource,
) -> Result<format::Manifest, TasksError> {
    generate_set_with_surface(out, seed, source, None)
}

/// [`generate_set`], or with `surface = Some(kind)` the set's surface counterfactual (every world on ground of
/// semantics kind `kind`, everything else unchanged; [`generate::generate_with_surface`]). The manifest's
/// generator then ends in ` surface=<kind>`, so the counterfactual has its own version and is never mistaken for
/// the benchmark's set. A set from any seed but the benchmark's must be held out from it
/// ([`generate::check_held_out`]).
pub fn generate_set_with_surface(
    out: &Path,
    seed: u64,
    source: &dyn HeightSource,
    surface: Option<SemanticsKind>,
) -> Result<format::Manifest, TasksError> {
    if seed != generate::DEFAULT_SEED {
        generate::check_held_out(seed)?;
    }
    let ids: Vec<u32> = (1..=crate::design::WORLDS).collect();
    let records = generate::generate_with_surface(seed, &ids, source, surface)?;
    let generator = match surface {
        None => source.name(),
        Some(k) => format!("{} surface={}", source.name(), k.as_str()),
    };
    format::save(out, Some(seed), &generator, &records)
}

/// Imports every world of an original release directory into `out`.
pub fn import_release(release: &Path, out: &Path) -> Result<format::Manifest, TasksError> {
    let records: Vec<WorldRecord> = import::discover(release)?
        .iter()
        .map(import::import_world)
        .collect::<Result<_, _>>()?;
    format::save(out, None, "import:verti-bench", &records)
}

/// Renders worlds `ids` (all when empty) to `out/world_NNN.png` and a contact sheet `out/contact_sheet.png`.
pub fn render_set(
    set: &TaskSet,
    ids: &[u32],
    out: &Path,
    ppm: u32,
) -> Result<Vec<String>, TasksError> {
    std::fs::create_dir_all(out).map_err(|e| TasksError::io(out, e))?;
    let ids = if ids.is_empty() {
        set.world_ids()
    } else {
        ids.to_vec()
    };
    let records: Vec<WorldRecord> = ids
        .iter()
        .map(|&id| set.record(id))
        .collect::<Result<_, _>>()?;
    let mut written = Vec::new();
    let save = |img: &image::RgbImage,
                name: String,
                written: &mut Vec<String>|
     -> Result<(), TasksError> {
        let path = out.join(name);
        img.save(&path).map_err(|e| TasksError::Image {
            path: path.clone(),
            message: e.to_string(),
        })?;
        written.push(path.display().to_string());
        Ok(())
    };
    for r in &records {
        save(
            &render::render_world(r, ppm.clamp(1, 16)),
            format!("world_{:03}.png", r.world.id),
            &mut written,
        )?;
    }
    save(
        &render::contact_sheet(&records, 10),
        "contact_sheet.png".into(),
        &mut written,
    )?;
    Ok(written)
}

/// Statistics of a task set.
pub fn stats(set: &TaskSet) -> Result<stats::TaskSetStats, TasksError> {
    Ok(stats::compute(&set.records()?))
}

/// Human-readable statistics table.
pub fn stats_text(s: &stats::TaskSetStats) -> String {
    let mut t = format!(
        "{} worlds, {} tasks, {} obstacles, mean path {:.1} m\n",
        s.worlds, s.tasks, s.obstacles, s.mean_path_length
    );
    t += &format!(
        "levels     {:?}\nsemantics  {:?}\ndensities  {:?}\n",
        s.by_level, s.by_semantics, s.by_density
    );
    t += "level   worlds  relief_m  std_m  slope_p50  slope_p95  slope_max  roughness_m\n";
    for (level, l) in &s.geometry_by_level {
        let g = &l.mean;
        t += &format!(
            "{level:<7} {:>6}  {:>8.2}  {:>5.2}  {:>9.1}  {:>9.1}  {:>9.1}  {:>11.3}\n",
            l.worlds,
            g.relief,
            g.height_std,
            g.slope_p50_deg,
            g.slope_p95_deg,
            g.slope_max_deg,
            g.roughness
        );
    }
    t
}
