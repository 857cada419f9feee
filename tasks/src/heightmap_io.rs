//! External elevation maps, so users can bring real terrain: 8- and 16-bit grayscale PNG or BMP, and `.npy`
//! arrays of float32/float64 (C order, little endian, 2-D).
//!
//! Images are read with row 0 at the north edge (the release's BMP orientation). Gray values map linearly to
//! `[min_height, max_height]`; `.npy` values are heights in metres and are used as they are.

use crate::TasksError;
use sim_core::world::Heightmap;
use std::path::Path;

/// Raw samples of a map file: `(width, height, values)`, values in row order with row 0 = north.
/// Image values are normalised to [0, 1]; `.npy` values are returned unchanged.
pub fn read_samples(path: &Path) -> Result<(usize, usize, Vec<f64>, bool), TasksError> {
    let bytes = std::fs::read(path).map_err(|e| TasksError::io(path, e))?;
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "npy" {
        let (w, h, v) = parse_npy(&bytes, path)?;
        return Ok((w, h, v, false));
    }
    let img = image::load_from_memory(&bytes).map_err(|e| TasksError::Image {
        path: path.into(),
        message: e.to_string(),
    })?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let values: Vec<f64> = match img {
        image::DynamicImage::ImageLuma16(i) => i
            .into_raw()
            .into_iter()
            .map(|v| v as f64 / 65535.0)
            .collect(),
        image::DynamicImage::ImageLuma8(i) => {
            i.into_raw().into_iter().map(|v| v as f64 / 255.0).collect()
        }
        other if other.color().has_color() || other.color().has_alpha() => {
            // Palette BMPs (as in the release) decode to RGB: take the luma of 8-bit images.
            other
                .to_luma8()
                .into_raw()
                .into_iter()
                .map(|v| v as f64 / 255.0)
                .collect()
        }
        other => {
            return Err(TasksError::Image {
                path: path.into(),
                message: format!(
                    "unsupported pixel format {:?}: use 8- or 16-bit grayscale",
                    other.color()
                ),
            })
        }
    };
    Ok((w, h, values, true))
}

/// Loads an elevation map as a [`Heightmap`] with `cell` metres per sample. Images map gray [0, max] to
/// `[min_height, max_height]`; `.npy` heights are taken as metres (the range arguments are ignored).
pub fn load_heightmap(
    path: &Path,
    cell: f64,
    min_height: f64,
    max_height: f64,
) -> Result<Heightmap, TasksError> {
    if !(cell.is_finite() && cell > 0.0) {
        return Err(TasksError::Param {
            field: "cell".into(),
            message: format!("{cell} is not a positive length"),
        });
    }
    if !(min_height.is_finite() && max_height.is_finite() && max_height >= min_height) {
        return Err(TasksError::Param {
            field: "max_height".into(),
            message: format!("height range [{min_height}, {max_height}] is empty or not finite"),
        });
    }
    let (w, h, values, normalised) = read_samples(path)?;
    if w < 2 || h < 2 {
        return Err(TasksError::Image {
            path: path.into(),
            message: format!("size {w} x {h} is too small"),
        });
    }
    if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
        return Err(TasksError::Image {
            path: path.into(),
            message: format!("sample {bad} is not finite"),
        });
    }
    let mut heights = vec![0f32; w * h];
    for row in 0..h {
        let iy = h - 1 - row;
        for ix in 0..w {
            let v = values[row * w + ix];
            let z = if normalised {
                min_height + v * (max_height - min_height)
            } else {
                v
            };
            heights[iy * w + ix] = z as f32;
        }
    }
    Ok(Heightmap {
        nx: w,
        ny: h,
        cell,
        heights,
    })
}

/// Parses a 2-D `.npy` array of `<f4`, `<f8`, `<i4`, `|u1` or `<u2` values in C order.
pub fn parse_npy(bytes: &[u8], path: &Path) -> Result<(usize, usize, Vec<f64>), TasksError> {
    let err = |m: String| TasksError::Image {
        path: path.into(),
        message: m,
    };
    if bytes.len() < 10 || &bytes[..6] != b"\x93NUMPY" {
        return Err(err("not a .npy file (bad magic)".into()));
    }
    let major = bytes[6];
    let (hlen, start) = match major {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (
            u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize,
            12,
        ),
        _ => return Err(err(format!("unsupported .npy version {major}"))),
    };
    let header = bytes
        .get(start..start + hlen)
        .ok_or_else(|| err("truncated header".into()))?;
    let header = std::str::from_utf8(header).map_err(|_| err("header is not text".into()))?;
    let field = |key: &str| -> Option<&str> {
        let at = header.find(&format!("'{key}'"))? + key.len() + 2;
        let rest = header[at..].trim_start().strip_prefix(':')?.trim_start();
        Some(rest)
    };
    let descr = field("descr")
        .and_then(|r| r.strip_prefix('\''))
        .and_then(|r| r.split('\'').next());
    let descr = descr.ok_or_else(|| err("header has no descr".into()))?;
    if field("fortran_order").is_some_and(|r| r.starts_with("True")) {
        return Err(err("Fortran-ordered arrays are not supported".into()));
    }
    let shape = field("shape")
        .and_then(|r| r.strip_prefix('('))
        .and_then(|r| r.split(')').next());
    let shape = shape.ok_or_else(|| err("header has no shape".into()))?;
    let dims: Vec<usize> = shape
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.parse().map_err(|_| err(format!("bad shape `{shape}`"))))
        .collect::<Result<_, _>>()?;
    let [h, w] = dims[..] else {
        return Err(err(format!("expected a 2-D array, shape is ({shape})")));
    };
    let data = &bytes[start + hlen..];
    let n = w
        .checked_mul(h)
        .ok_or_else(|| err("shape overflows".into()))?;
    let (size, conv): (usize, fn(&[u8]) -> f64) = match descr {
        "<f4" => (4, |b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64),
        "<f8" => (8, |b| f64::from_le_bytes(b.try_into().expect("8 bytes"))),
        "<i4" => (4, |b| i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64),
        "<i8" => (8, |b| {
            i64::from_le_bytes(b.try_into().expect("8 bytes")) as f64
        }),
        "|u1" => (1, |b| b[0] as f64),
        "<u2" => (2, |b| u16::from_le_bytes([b[0], b[1]]) as f64),
        other => return Err(err(format!("unsupported dtype `{other}`"))),
    };
    if data.len() < n * size {
        return Err(err(format!(
            "data holds {} bytes, shape ({shape}) needs {}",
            data.len(),
            n * size
        )));
    }
    Ok((
        w,
        h,
        data[..n * size].chunks_exact(size).map(conv).collect(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn npy(descr: &str, shape: &str, data: &[u8]) -> Vec<u8> {
        let mut header =
            format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': ({shape}), }}");
        while (10 + header.len() + 1) % 64 != 0 {
            header.push(' ');
        }
        header.push('\n');
        let mut out = b"\x93NUMPY\x01\x00".to_vec();
        out.extend_from_slice(&(header.len() as u16).to_le_bytes());
        out.extend_from_slice(header.as_bytes());
        out.extend_from_slice(data);
        out
    }

    #[test]
    fn npy_float_maps_load_with_north_up_rows() {
        let vals: Vec<u8> = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        let dir = std::env::temp_dir().join(format!("vb-npy-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("m.npy");
        std::fs::write(&p, npy("<f4", "2, 3", &vals)).unwrap();
        let h = load_heightmap(&p, 0.5, 0.0, 1.0).unwrap();
        assert_eq!((h.nx, h.ny), (3, 2));
        // Row 0 of the file is the north edge: iy = 1.
        assert_eq!(h.at(0, 1), 1.0);
        assert_eq!(h.at(2, 0), 6.0);
        assert_eq!(h.cell, 0.5);
    }

    #[test]
    fn bad_npy_files_get_clear_errors() {
        let p = Path::new("x.npy");
        let e = parse_npy(b"hello world", p).unwrap_err().to_string();
        assert!(e.contains("x.npy") && e.contains("magic"), "{e}");
        let e = parse_npy(&npy("<f4", "2, 3", &[0; 8]), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("needs 24"), "{e}");
        let e = parse_npy(&npy("<c16", "2, 3", &[0; 96]), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("unsupported dtype"), "{e}");
        let e = parse_npy(&npy("<f4", "2, 3, 4", &[0; 96]), p)
            .unwrap_err()
            .to_string();
        assert!(e.contains("2-D"), "{e}");
    }

    #[test]
    fn sixteen_bit_png_maps_to_the_height_range() {
        let dir = std::env::temp_dir().join(format!("vb-png-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("m.png");
        let img: image::ImageBuffer<image::Luma<u16>, Vec<u16>> =
            image::ImageBuffer::from_raw(2, 2, vec![0, 65535, 32768, 0]).unwrap();
        img.save(&p).unwrap();
        let h = load_heightmap(&p, 1.0, 1.0, 3.0).unwrap();
        assert!((h.at(1, 1) - 3.0).abs() < 1e-6);
        assert!((h.at(0, 0) - 2.0).abs() < 1e-3);
        let e = load_heightmap(&p, 1.0, 3.0, 1.0).unwrap_err().to_string();
        assert!(e.contains("max_height"), "{e}");
        let e = load_heightmap(&dir.join("missing.png"), 1.0, 0.0, 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing.png"), "{e}");
    }
}
