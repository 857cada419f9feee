//! The card's pictures: driven paths over a few worlds (PNG, over the task set's map when it is given) and
//! histograms of speed, roll and pitch (SVG). What they need is gathered file by file as the dataset is written or
//! resumed ([`CardData`]); drawing uses no clock or randomness, so the same frames give the same bytes.

use crate::episodes::EpisodeMetaRow;
use crate::frames::FrameColumns;
use contracts::Outcome;
use image::{Rgb, RgbImage};
use std::fmt::Write as _;

/// Worlds shown in the paths picture, and episodes drawn per world.
const PATH_WORLDS: usize = 4;
const PATHS_PER_WORLD: usize = 12;
/// Points kept per drawn path.
const PATH_POINTS: usize = 400;

/// A histogram with fixed bins (so it can be filled file by file) and counts outside them.
#[derive(Clone, Debug, PartialEq)]
pub struct Hist {
    pub lo: f64,
    pub width: f64,
    pub counts: Vec<u64>,
    pub below: u64,
    pub above: u64,
}

impl Hist {
    pub fn new(lo: f64, hi: f64, bins: usize) -> Hist {
        Hist {
            lo,
            width: (hi - lo) / bins as f64,
            counts: vec![0; bins],
            below: 0,
            above: 0,
        }
    }
    pub fn add(&mut self, x: f64) {
        let b = ((x - self.lo) / self.width).floor();
        if b < 0.0 {
            self.below += 1;
        } else if b >= self.counts.len() as f64 {
            self.above += 1;
        } else {
            self.counts[b as usize] += 1;
        }
    }
}

/// One drawn path.
#[derive(Clone, Debug, PartialEq)]
pub struct PathLine {
    pub episode: u64,
    pub outcome: Outcome,
    /// World-frame positions (at the dataset's scale), subsampled.
    pub points: Vec<[f64; 2]>,
    pub goal: [f64; 2],
}

/// What the card's pictures need, gathered from the frames in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct CardData {
    pub speed: Hist,
    pub roll: Hist,
    pub pitch: Hist,
    /// The first [`PATH_WORLDS`] worlds met, each with its first [`PATHS_PER_WORLD`] episodes.
    pub worlds: Vec<(u32, Vec<PathLine>)>,
}

impl Default for CardData {
    fn default() -> Self {
        CardData {
            speed: Hist::new(-10.0, 30.0, 400),
            roll: Hist::new(-90.0, 90.0, 360),
            pitch: Hist::new(-90.0, 90.0, 360),
            worlds: Vec::new(),
        }
    }
}

impl CardData {
    /// Adds a data file's frames; `rows` are its episodes, in order.
    pub fn add(&mut self, frames: &FrameColumns, rows: &[EpisodeMetaRow]) {
        let s = &frames.state;
        for r in 0..frames.rows.min(s.len() / 15) {
            self.speed.add(s[r * 15 + 12]);
            self.roll.add(s[r * 15 + 3].to_degrees());
            self.pitch.add(s[r * 15 + 4].to_degrees());
        }
        for ((_, range), row) in frames.episode_ranges().into_iter().zip(rows) {
            let w = row.meta.world_id;
            let slot = match self.worlds.iter().position(|(id, _)| *id == w) {
                Some(i) => i,
                None if self.worlds.len() < PATH_WORLDS => {
                    self.worlds.push((w, Vec::new()));
                    self.worlds.len() - 1
                }
                None => continue,
            };
            let lines = &mut self.worlds[slot].1;
            if lines.len() >= PATHS_PER_WORLD || range.end * 15 > s.len() {
                continue;
            }
            let step = range.len().div_ceil(PATH_POINTS).max(1);
            let mut points: Vec<[f64; 2]> = range
                .clone()
                .step_by(step)
                .map(|r| [s[r * 15], s[r * 15 + 1]])
                .collect();
            if let Some(last) = range.clone().last() {
                points.push([s[last * 15], s[last * 15 + 1]]);
            }
            lines.push(PathLine {
                episode: row.index,
                outcome: row.meta.outcome,
                points,
                goal: row.meta.goal,
            });
        }
    }
}

/// The colour a path of this outcome is drawn in, and its name in the legend.
pub fn outcome_colour(o: Outcome) -> ([u8; 3], &'static str) {
    match o {
        Outcome::Success => ([20, 150, 60], "green"),
        Outcome::Rollover => ([220, 30, 30], "red"),
        Outcome::Stuck => ([245, 150, 20], "orange"),
        Outcome::Timeout => ([40, 90, 230], "blue"),
        Outcome::OffMap => ([160, 50, 200], "purple"),
        Outcome::PlannerFailure => ([0, 0, 0], "black"),
        Outcome::Cancelled => ([120, 120, 120], "grey"),
    }
}

/// A world's tile: its map (from the task set) or a blank one, and how to map world points onto it.
pub struct Tile {
    pub image: RgbImage,
    /// World point (dataset scale) to pixel.
    pub to_px: Box<dyn Fn([f64; 2]) -> (f64, f64)>,
}

/// A blank tile spanning the paths' bounding box (when no task set is given).
pub fn blank_tile(lines: &[PathLine], size: u32) -> Tile {
    let pts = lines
        .iter()
        .flat_map(|l| l.points.iter().chain(std::iter::once(&l.goal)));
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in pts {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let span = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-6) * 1.1;
    let centre = [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0];
    let px = f64::from(size);
    Tile {
        image: RgbImage::from_pixel(size, size, Rgb([235, 235, 235])),
        to_px: Box::new(move |p| {
            (
                ((p[0] - centre[0]) / span + 0.5) * px,
                (0.5 - (p[1] - centre[1]) / span) * px,
            )
        }),
    }
}

/// Draws the paths onto a tile: each path in its outcome's colour, its start and goal as dots.
pub fn draw_paths(tile: &mut Tile, lines: &[PathLine]) {
    let w = (f64::from(tile.image.width()) / 130.0).max(2.0);
    for l in lines {
        let (c, _) = outcome_colour(l.outcome);
        // A white halo first, so paths stand out on any ground.
        for (width, colour) in [(w + 2.0, [255, 255, 255]), (w, c)] {
            for seg in l.points.windows(2) {
                tasks::render::line(
                    &mut tile.image,
                    (tile.to_px)(seg[0]),
                    (tile.to_px)(seg[1]),
                    width,
                    colour,
                );
            }
        }
        if let Some(&s) = l.points.first() {
            let p = (tile.to_px)(s);
            tasks::render::line(&mut tile.image, p, p, 3.0 * w, [255, 255, 255]);
            tasks::render::line(&mut tile.image, p, p, 1.5 * w, [0, 0, 0]);
        }
        let g = (tile.to_px)(l.goal);
        tasks::render::line(&mut tile.image, g, g, 3.0 * w, [255, 215, 0]);
    }
}

/// Tiles side by side in rows of two, with a white gap.
pub fn sheet(tiles: &[RgbImage]) -> RgbImage {
    let tw = tiles.iter().map(|t| t.width()).max().unwrap_or(1);
    let th = tiles.iter().map(|t| t.height()).max().unwrap_or(1);
    let cols = tiles.len().clamp(1, 2) as u32;
    let rows = (tiles.len() as u32).div_ceil(cols).max(1);
    let gap = 6;
    let mut out = RgbImage::from_pixel(
        cols * (tw + gap) + gap,
        rows * (th + gap) + gap,
        Rgb([255, 255, 255]),
    );
    for (k, t) in tiles.iter().enumerate() {
        let (c, r) = (k as u32 % cols, k as u32 / cols);
        image::imageops::overlay(
            &mut out,
            t,
            i64::from(gap + c * (tw + gap)),
            i64::from(gap + r * (th + gap)),
        );
    }
    out
}

/// A histogram as SVG: the populated range in at most 40 bars, axis labels, and the counts outside the bins.
pub fn histogram_svg(h: &Hist, title: &str, unit: &str) -> String {
    let (w, ht, left, bottom, top) = (480.0, 260.0, 56.0, 40.0, 30.0);
    let mut svg = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{ht}\" viewBox=\"0 0 {w} {ht}\" \
         font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"{w}\" height=\"{ht}\" fill=\"white\"/>\n\
         <text x=\"{}\" y=\"18\" text-anchor=\"middle\" font-size=\"13\">{title}</text>\n",
        w / 2.0
    );
    let first = h.counts.iter().position(|&c| c > 0);
    let last = h.counts.iter().rposition(|&c| c > 0);
    let (Some(first), Some(last)) = (first, last) else {
        svg += "<text x=\"240\" y=\"130\" text-anchor=\"middle\">no frames</text>\n</svg>\n";
        return svg;
    };
    let merge = (last - first + 1).div_ceil(40).max(1);
    let bars: Vec<(f64, u64)> = (first..=last)
        .step_by(merge)
        .map(|b| {
            (
                h.lo + b as f64 * h.width,
                h.counts[b..(b + merge).min(h.counts.len())].iter().sum(),
            )
        })
        .collect();
    let peak = bars.iter().map(|b| b.1).max().unwrap_or(1).max(1);
    let (pw, ph) = (w - left - 16.0, ht - top - bottom);
    let bw = pw / bars.len() as f64;
    for (i, (_, c)) in bars.iter().enumerate() {
        let bh = *c as f64 / peak as f64 * ph;
        let _ = writeln!(
            svg,
            "<rect x=\"{:.2}\" y=\"{:.2}\" width=\"{:.2}\" height=\"{:.2}\" fill=\"#4a78c2\"/>",
            left + i as f64 * bw,
            top + ph - bh,
            (bw - 1.0).max(0.5),
            bh
        );
    }
    let base = top + ph;
    let _ = writeln!(
        svg,
        "<line x1=\"{left}\" y1=\"{base}\" x2=\"{}\" y2=\"{base}\" stroke=\"black\"/>\n\
         <line x1=\"{left}\" y1=\"{top}\" x2=\"{left}\" y2=\"{base}\" stroke=\"black\"/>\n\
         <text x=\"{}\" y=\"{}\" text-anchor=\"end\">{peak}</text>\n\
         <text x=\"{}\" y=\"{base}\" text-anchor=\"end\">0</text>",
        left + pw,
        left - 4.0,
        top + 4.0,
        left - 4.0
    );
    let span_hi = h.lo + (first + bars.len() * merge) as f64 * h.width;
    for k in 0..=4 {
        let x = left + pw * k as f64 / 4.0;
        let v = bars[0].0 + (span_hi - bars[0].0) * k as f64 / 4.0;
        let _ = writeln!(
            svg,
            "<text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{v:.1}</text>",
            base + 14.0
        );
    }
    let mut note = format!(
        "{unit}; bars {:.1} wide, heights in frames",
        h.width * merge as f64
    );
    if h.below + h.above > 0 {
        let _ = write!(note, "; {} below, {} above the range", h.below, h.above);
    }
    let _ = writeln!(
        svg,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{note}</text>\n</svg>",
        w / 2.0,
        ht - 6.0
    );
    svg
}
