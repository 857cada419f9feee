//! Contact sheet of the generator (`vb terrain render`): rows of held-out crops, their reconstructions, samples of
//! the generator and, for comparison, training crops; each tile a grey hill shade of the map with a decoded +1 at
//! [`SHADE_SCALE`] m (the original release's 16 m, which keeps the rough training crops readable), 128 x 128 px.

use crate::eval::as_heightmap;
use crate::CROP_PX;
use image::{GrayImage, Luma};

/// Height of a decoded +1 in the pictures, m.
pub const SHADE_SCALE: f64 = 16.0;

/// Tiles `rows` of maps (normalised units) into one picture with a gap of 4 px.
pub fn sheet(rows: &[Vec<Vec<f64>>], full_scale: f64) -> GrayImage {
    let gap = 4u32;
    let cols = rows.iter().map(|r| r.len()).max().unwrap_or(0) as u32;
    let t = CROP_PX as u32;
    let mut img = GrayImage::from_pixel(
        cols * (t + gap) + gap,
        rows.len() as u32 * (t + gap) + gap,
        Luma([255]),
    );
    for (r, row) in rows.iter().enumerate() {
        for (c, map) in row.iter().enumerate() {
            // Image row 0 = north: flip so that hillshade (north up) shows the map as stored.
            let mut flipped = vec![0.0; map.len()];
            for y in 0..CROP_PX {
                flipped[y * CROP_PX..(y + 1) * CROP_PX]
                    .copy_from_slice(&map[(CROP_PX - 1 - y) * CROP_PX..(CROP_PX - y) * CROP_PX]);
            }
            let tile = tasks::render::hillshade(&as_heightmap(&flipped, full_scale));
            let (x0, y0) = (gap + c as u32 * (t + gap), gap + r as u32 * (t + gap));
            for (x, y, p) in tile.enumerate_pixels() {
                img.put_pixel(x0 + x, y0 + y, Luma([p[0]]));
            }
        }
    }
    img
}

/// The contact sheet of `vb terrain render`: `columns` held-out crops, their reconstructions, generated samples
/// (seeds 0, 1, ...) and training crops, one row each.
pub fn contact_sheet(
    data: &std::path::Path,
    weights: &std::path::Path,
    columns: usize,
) -> Result<GrayImage, crate::SwaeError> {
    let (train, val) = crate::train::load_split(data)?;
    let model = crate::model::Swae::load(weights)?;
    let src = crate::SwaeSource::from_file(weights, crate::source::FULL_SCALE_HEIGHT)?;
    let k = columns.min(val.len()).min(train.len());
    let to64 = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<f64>>();
    let held: Vec<Vec<f64>> = val[..k].iter().map(|c| to64(&c.values)).collect();
    let rec: Vec<Vec<f64>> = crate::train::reconstruct(&model, &val[..k])?
        .iter()
        .map(|r| to64(r))
        .collect();
    let gen = crate::eval::samples(&src, k)?;
    let tr: Vec<Vec<f64>> = train[..k].iter().map(|c| to64(&c.values)).collect();
    Ok(sheet(&[held, rec, gen, tr], SHADE_SCALE))
}
