//! Geometry statistics of a heightmap, used to calibrate and check the terrain generator against the original
//! worlds and reported by `vb tasks stats`.
//!
//! Definitions (all on the sample grid, interior samples for gradients):
//! - relief: max height - min height, m;
//! - slope: `atan(|grad h|)` with central differences, degrees; reported as percentiles;
//! - roughness: standard deviation of `h - mean(h over the 3 x 3 neighbourhood)`, m.

use crate::world::Heightmap;

/// Summary geometry statistics of one heightmap.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct GeometryStats {
    pub relief: f64,
    pub height_std: f64,
    pub slope_mean_deg: f64,
    pub slope_p50_deg: f64,
    pub slope_p95_deg: f64,
    pub slope_max_deg: f64,
    pub roughness: f64,
}

/// Slope angles of all interior samples, degrees (unsorted, row-major).
pub fn slopes_deg(h: &Heightmap) -> Vec<f64> {
    let mut out = Vec::with_capacity(h.nx.saturating_sub(2) * h.ny.saturating_sub(2));
    for iy in 1..h.ny.saturating_sub(1) {
        for ix in 1..h.nx.saturating_sub(1) {
            let gx = (h.at(ix + 1, iy) - h.at(ix - 1, iy)) / (2.0 * h.cell);
            let gy = (h.at(ix, iy + 1) - h.at(ix, iy - 1)) / (2.0 * h.cell);
            out.push((gx * gx + gy * gy).sqrt().atan().to_degrees());
        }
    }
    out
}

/// Percentile `p` in [0, 100] of `values` by nearest rank on a sorted copy; 0 for an empty slice.
pub fn percentile(values: &[f64], p: f64) -> f64 {
    if values.is_empty() {
        return 0.0;
    }
    let mut v = values.to_vec();
    v.sort_by(|a, b| a.total_cmp(b));
    let rank = ((p / 100.0) * (v.len() - 1) as f64).round() as usize;
    v[rank.min(v.len() - 1)]
}

/// Computes [`GeometryStats`] of a heightmap.
pub fn geometry_stats(h: &Heightmap) -> GeometryStats {
    let n = h.heights.len().max(1) as f64;
    let (mut lo, mut hi, mut sum) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for &v in &h.heights {
        let v = v as f64;
        lo = lo.min(v);
        hi = hi.max(v);
        sum += v;
    }
    let mean = sum / n;
    let var = h
        .heights
        .iter()
        .map(|&v| (v as f64 - mean).powi(2))
        .sum::<f64>()
        / n;
    let mut slopes = slopes_deg(h);
    slopes.sort_by(|a, b| a.total_cmp(b));
    let pick = |p: f64| {
        if slopes.is_empty() {
            0.0
        } else {
            slopes[((p / 100.0) * (slopes.len() - 1) as f64).round() as usize]
        }
    };
    let slope_mean = slopes.iter().sum::<f64>() / slopes.len().max(1) as f64;
    let mut dev = Vec::new();
    for iy in 1..h.ny.saturating_sub(1) {
        for ix in 1..h.nx.saturating_sub(1) {
            let mut s = 0.0;
            for dy in 0..3 {
                for dx in 0..3 {
                    s += h.at(ix + dx - 1, iy + dy - 1);
                }
            }
            dev.push(h.at(ix, iy) - s / 9.0);
        }
    }
    let dm = dev.iter().sum::<f64>() / dev.len().max(1) as f64;
    let rough =
        (dev.iter().map(|d| (d - dm).powi(2)).sum::<f64>() / dev.len().max(1) as f64).sqrt();
    GeometryStats {
        relief: if h.heights.is_empty() { 0.0 } else { hi - lo },
        height_std: var.sqrt(),
        slope_mean_deg: slope_mean,
        slope_p50_deg: pick(50.0),
        slope_p95_deg: pick(95.0),
        slope_max_deg: slopes.last().copied().unwrap_or(0.0),
        roughness: rough,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plane(slope: f64) -> Heightmap {
        let n = 9;
        let heights = (0..n * n)
            .map(|i| ((i % n) as f64 * slope) as f32)
            .collect();
        Heightmap {
            nx: n,
            ny: n,
            cell: 1.0,
            heights,
        }
    }

    #[test]
    fn inclined_plane_has_uniform_slope_and_no_roughness() {
        let s = geometry_stats(&plane(0.5));
        let expect = 0.5f64.atan().to_degrees();
        assert!((s.slope_p95_deg - expect).abs() < 1e-4, "{s:?}");
        assert!((s.slope_max_deg - expect).abs() < 1e-4);
        assert!((s.relief - 4.0).abs() < 1e-6);
        assert!(s.roughness < 1e-6);
    }

    #[test]
    fn percentile_by_nearest_rank() {
        let v: Vec<f64> = (0..=100).map(f64::from).collect();
        assert_eq!(percentile(&v, 95.0), 95.0);
        assert_eq!(percentile(&[], 50.0), 0.0);
    }
}
