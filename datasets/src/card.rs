//! The dataset card: `README.md` (provenance, command line, counts, simulated hours, the outcome mix by level,
//! semantics and density) and its pictures in `card/` (driven paths over a few worlds, histograms of speed, roll
//! and pitch). No clock: the same dataset gives the same bytes.

use crate::episodes::EpisodeMetaRow;
use crate::error::DatasetError;
use crate::layout::{write_atomic, CARD, CARD_DIR};
use crate::meta::{Layout, Totals, CODEBASE_VERSION, FORMAT};
use crate::plot::{blank_tile, draw_paths, histogram_svg, outcome_colour, sheet, CardData, Tile};
use crate::record::DatasetKind;
use crate::spec::{DatasetSpec, SpeedProfile, Variant};
use contracts::Outcome;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// Everything the card shows.
pub struct CardInput<'a> {
    pub spec: &'a DatasetSpec,
    pub command: &'a str,
    pub layout: &'a Layout,
    pub totals: &'a Totals,
    pub episodes: &'a [EpisodeMetaRow],
    pub tasks: &'a [String],
    pub data: &'a CardData,
    /// The task set the episodes ran on: the paths are drawn over its maps (over a blank ground without it).
    pub task_set: Option<&'a tasks::TaskSet>,
}

fn world_tile(ts: &tasks::TaskSet, world: u32, scale: f64) -> Result<Tile, DatasetError> {
    let mut rec = ts
        .record(world)
        .map_err(|e| DatasetError::TaskSet(format!("{}: {e}", ts.dir.display())))?;
    rec.tasks.clear();
    let hm = rec.world.heightmap.clone();
    let ppm = (360 / hm.nx.max(1) as u32).clamp(1, 4);
    let image = tasks::render::render_world(&rec, ppm);
    let p = f64::from(ppm);
    Ok(Tile {
        image,
        to_px: Box::new(move |q| {
            let (fx, fy) = hm.grid_coords(q[0] / scale, q[1] / scale);
            ((fx + 0.5) * p, ((hm.ny - 1) as f64 - fy + 0.5) * p)
        }),
    })
}

fn png(path: &Path, img: &image::RgbImage) -> Result<Vec<u8>, DatasetError> {
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .map_err(|e| {
            DatasetError::TaskSet(format!("{}: encoding the picture: {e}", path.display()))
        })?;
    Ok(out)
}

/// Writes `card/*` and `README.md` into `root`.
pub fn write_card(root: &Path, input: &CardInput) -> Result<(), DatasetError> {
    let spec = input.spec;
    if let Some(ts) = input.task_set {
        if ts.version() != spec.task_set_version {
            return Err(DatasetError::TaskSet(format!(
                "{} is version `{}`, the dataset was generated on `{}`",
                ts.dir.display(),
                ts.version(),
                spec.task_set_version
            )));
        }
    }
    let dir = root.join(CARD_DIR);
    let mut tiles = Vec::new();
    for (world, lines) in &input.data.worlds {
        let mut tile = match input.task_set {
            Some(ts) => world_tile(ts, *world, spec.scale)?,
            None => blank_tile(lines, 300),
        };
        draw_paths(&mut tile, lines);
        tiles.push(tile.image);
    }
    if !tiles.is_empty() {
        let path = dir.join("paths.png");
        write_atomic(&path, &png(&path, &sheet(&tiles))?)?;
    }
    let d = input.data;
    for (name, h, title, unit) in [
        ("speed.svg", &d.speed, "Forward speed", "m/s"),
        ("roll.svg", &d.roll, "Roll", "degrees"),
        ("pitch.svg", &d.pitch, "Pitch", "degrees"),
    ] {
        write_atomic(&dir.join(name), histogram_svg(h, title, unit).as_bytes())?;
    }
    write_atomic(
        &root.join(CARD),
        readme(input, !tiles.is_empty()).as_bytes(),
    )
}

fn describe(kind: DatasetKind) -> &'static str {
    match kind {
        DatasetKind::Expert => "Successful episodes of the benchmark's built-in planners (expert demonstrations).",
        DatasetKind::Random => {
            "Random exploration (the paper's): sinusoidal steering at a commanded speed, wherever it leads."
        }
        DatasetKind::Failures => "Failure cases: the last 10 s before a rollover or a stuck, labelled with the class.",
    }
}

fn pct(n: u64, of: u64) -> String {
    format!("{n} ({:.0}%)", 100.0 * n as f64 / of.max(1) as f64)
}

/// A table of outcome counts by one factor (rows in the factor's order, outcomes that occur as columns).
fn outcome_table(
    out: &mut String,
    title: &str,
    episodes: &[EpisodeMetaRow],
    key: &dyn Fn(&EpisodeMetaRow) -> (usize, String),
) {
    let outcomes: Vec<Outcome> = Outcome::ALL
        .iter()
        .copied()
        .filter(|o| episodes.iter().any(|e| e.meta.outcome == *o))
        .collect();
    let mut rows: BTreeMap<(usize, String), BTreeMap<Outcome, u64>> = BTreeMap::new();
    for e in episodes {
        *rows
            .entry(key(e))
            .or_default()
            .entry(e.meta.outcome)
            .or_default() += 1;
    }
    let _ = writeln!(out, "\n### By {title}\n");
    let head: Vec<&str> = outcomes.iter().map(|o| o.as_str()).collect();
    let _ = writeln!(out, "| {title} | episodes | {} |", head.join(" | "));
    let _ = writeln!(out, "|---|---:|{}", "---:|".repeat(outcomes.len()));
    for ((_, name), counts) in &rows {
        let total: u64 = counts.values().sum();
        let cells: Vec<String> = outcomes
            .iter()
            .map(|o| pct(counts.get(o).copied().unwrap_or(0), total))
            .collect();
        let _ = writeln!(out, "| {name} | {total} | {} |", cells.join(" | "));
    }
}

/// The speed profile's and the analysis-only flag's notes.
fn profile_notes(s: &mut String, spec: &DatasetSpec) {
    match spec.speed_profile {
        SpeedProfile::Constant => {}
        SpeedProfile::StopAndGo => {
            *s += "\nStop-and-go speed profile: the commanded speed stops periodically, alternately braked and coasting \
                  (policy parameters `stop_go`, `stop_duration`, `stop_offset`).\n";
        }
        SpeedProfile::Fast => {
            let [lo, hi] = crate::generate::random::FAST_SPEED;
            let _ = writeln!(
                s,
                "\nFast speed profile: the commanded speed is drawn per episode from {lo} to {hi} m/s at full scale \
                 (policy parameter `speed`), so the data holds rollovers."
            );
        }
    }
    if spec.analysis_only {
        *s += "\n**For analysis only.** Made from the benchmark's own tasks (`--allow-benchmark-tasks`): never train a \
              system that is evaluated on the benchmark with it.\n";
    }
}

/// The provenance table and the command that made the dataset.
fn provenance(s: &mut String, input: &CardInput, kind: &str, variant: &str) {
    let spec = input.spec;
    let crop = match spec.variant {
        Variant::Full => format!(
            "{0} x {0} cells of {1} m, stored (float16)",
            spec.crop.size, spec.crop.resolution
        ),
        Variant::Lite => format!(
            "not stored; rebuild {0} x {0} cells of {1} m from the task set and the pose",
            spec.crop.size, spec.crop.resolution
        ),
    };
    let seed = spec
        .task_set_seed
        .map_or("none (imported)".to_string(), |v| v.to_string());
    let _ = writeln!(
        s,
        "\n## Provenance\n\n| | |\n|---|---|\n| kind | {kind} |\n| variant | {variant} |\n| vehicle | {} ({} wheels) |\n\
         | scale | {} |\n| control rate (fps) | {} Hz |\n| map crops | {crop} |\n| simulator version | {} |\n\
         | task set version | {} |\n| task set seed | {seed} |\n| run seed | {} |\n| analysis only | {} |\n\
         | data file size | {} MB |\n| files per chunk | {} |\n\nMade by:\n\n```\n{}\n```",
        spec.vehicle,
        spec.wheels,
        spec.scale,
        spec.control_rate_hz,
        spec.sim_version,
        spec.task_set_version,
        spec.seed,
        spec.analysis_only,
        input.layout.data_files_size_in_mb,
        input.layout.chunks_size,
        input.command
    );
}

/// The driven paths' figure and its legend.
fn driven_paths(s: &mut String, input: &CardInput) {
    let worlds: Vec<String> = input
        .data
        .worlds
        .iter()
        .map(|(w, l)| format!("world {w} ({} episodes)", l.len()))
        .collect();
    let legend: Vec<String> = Outcome::ALL
        .iter()
        .filter(|o| {
            input
                .data
                .worlds
                .iter()
                .any(|(_, l)| l.iter().any(|p| p.outcome == **o))
        })
        .map(|o| format!("{} {}", outcome_colour(*o).1, o))
        .collect();
    let ground = if input.task_set.is_some() {
        "over the world's map"
    } else {
        "(no task set given: no map)"
    };
    let _ = writeln!(
        s,
        "\n## Driven paths\n\n![Driven paths](card/paths.png)\n\nThe first episodes of {}, {ground}; starts \
         white with a black centre, goals yellow; paths by outcome: {}.",
        worlds.join(", "),
        legend.join(", ")
    );
}

fn readme(input: &CardInput, paths: bool) -> String {
    let (spec, t) = (input.spec, input.totals);
    let kind = serde_json::to_value(spec.kind)
        .ok()
        .and_then(|v| v.as_str().map(str::to_string))
        .unwrap_or_default();
    let variant = match spec.variant {
        Variant::Lite => "lite",
        Variant::Full => "full",
    };
    let mut s = String::from("---\ntags:\n- LeRobot\n- vertibench\n- off-road\n- robotics\nconfigs:\n- config_name: default\n  data_files: data/*/*.parquet\n---\n\n");
    let _ = writeln!(
        s,
        "# vertibench {kind} dataset ({variant})\n\n{}",
        describe(spec.kind)
    );
    profile_notes(&mut s, spec);
    let _ = writeln!(
        s,
        "\nLeRobot {CODEBASE_VERSION} layout ({FORMAT}): frames in `data/`, one row per control step; episodes in \
         `meta/episodes/`; features, dtypes and shapes in `meta/info.json`; normalisation statistics in \
         `meta/stats.json`.\n\n## Counts\n\n| episodes | frames | simulated hours | data files | tasks |\n\
         |---:|---:|---:|---:|---:|\n| {} | {} | {:.2} | {} | {} |",
        t.episodes,
        t.frames,
        t.simulated_hours,
        t.data_files,
        input.tasks.len()
    );
    provenance(&mut s, input, &kind, variant);
    s += "\n## Outcomes\n";
    let eps = input.episodes;
    outcome_table(&mut s, "elevation level", eps, &|e| {
        (e.meta.level as usize, e.meta.level.to_string())
    });
    outcome_table(&mut s, "semantics", eps, &|e| {
        (e.meta.semantics as usize, e.meta.semantics.to_string())
    });
    outcome_table(&mut s, "obstacle density", eps, &|e| {
        (e.meta.density as usize, e.meta.density.to_string())
    });
    s += "\n## Tasks\n\n| task_index | task | episodes |\n|---:|---|---:|\n";
    for (i, task) in input.tasks.iter().enumerate() {
        let n = eps.iter().filter(|e| &e.task == task).count();
        let _ = writeln!(s, "| {i} | {task} | {n} |");
    }
    if paths {
        driven_paths(&mut s, input);
    }
    s += "\n## Speed, roll and pitch\n\n![Forward speed](card/speed.svg)\n![Roll](card/roll.svg)\n\
          ![Pitch](card/pitch.svg)\n";
    s
}
