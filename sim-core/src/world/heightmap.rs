//! The terrain's height grid ([`Heightmap`]); the indexing convention is in [`crate::world`]'s docs.

use super::MAP_PX;
use serde::{Deserialize, Serialize};

/// A regular height grid; see the module docs for the indexing convention.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Heightmap {
    pub nx: usize,
    pub ny: usize,
    /// Sample spacing, m.
    pub cell: f64,
    /// Heights, m, `heights[iy * nx + ix]`.
    pub heights: Vec<f32>,
}

impl Heightmap {
    /// A `MAP_PX x MAP_PX` map at `cell` metres whose height at world point `(x, y)` is `f(x, y)`.
    pub fn from_fn(cell: f64, f: impl Fn(f64, f64) -> f64) -> Heightmap {
        let n = MAP_PX;
        let mut heights = vec![0f32; n * n];
        let half = (n - 1) as f64 / 2.0;
        for iy in 0..n {
            for ix in 0..n {
                heights[iy * n + ix] =
                    f((ix as f64 - half) * cell, (iy as f64 - half) * cell) as f32;
            }
        }
        Heightmap {
            nx: n,
            ny: n,
            cell,
            heights,
        }
    }

    /// Height at sample `(ix, iy)`.
    #[inline]
    pub fn at(&self, ix: usize, iy: usize) -> f64 {
        self.heights[iy * self.nx + ix] as f64
    }
    /// Half extent of the map along x, m.
    pub fn half_x(&self) -> f64 {
        (self.nx - 1) as f64 * self.cell * 0.5
    }
    /// Half extent of the map along y, m.
    pub fn half_y(&self) -> f64 {
        (self.ny - 1) as f64 * self.cell * 0.5
    }
    /// Continuous grid coordinates `(fx, fy)` of a world point (sample units, not clamped).
    #[inline]
    pub fn grid_coords(&self, x: f64, y: f64) -> (f64, f64) {
        (
            x / self.cell + (self.nx - 1) as f64 * 0.5,
            y / self.cell + (self.ny - 1) as f64 * 0.5,
        )
    }
    /// World position of sample `(ix, iy)`.
    #[inline]
    pub fn sample_position(&self, ix: usize, iy: usize) -> (f64, f64) {
        (
            (ix as f64 - (self.nx - 1) as f64 * 0.5) * self.cell,
            (iy as f64 - (self.ny - 1) as f64 * 0.5) * self.cell,
        )
    }
    /// The 8-connected neighbours of sample index `idx` (`iy * nx + ix`) that lie on the grid, each with its step
    /// length in cells (1 or sqrt 2), in a fixed order (E, W, N, S, NE, SE, NW, SW): the moves of the grid
    /// searches (the task set's A*, the MPPI-6 cost-to-go). Allocates nothing.
    pub fn grid_neighbours(&self, idx: usize) -> impl Iterator<Item = (usize, f64)> {
        const MOVES: [(i64, i64); 8] = [
            (1, 0),
            (-1, 0),
            (0, 1),
            (0, -1),
            (1, 1),
            (1, -1),
            (-1, 1),
            (-1, -1),
        ];
        let (nx, ny) = (self.nx as i64, self.ny as i64);
        let (x, y) = ((idx % self.nx) as i64, (idx / self.nx) as i64);
        MOVES.into_iter().filter_map(move |(dx, dy)| {
            let (qx, qy) = (x + dx, y + dy);
            (qx >= 0 && qy >= 0 && qx < nx && qy < ny).then(|| {
                let step = if dx != 0 && dy != 0 {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                };
                ((qy * nx + qx) as usize, step)
            })
        })
    }
    /// Whether a world point lies on the map.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        x.abs() <= self.half_x() && y.abs() <= self.half_y()
    }
    /// Bilinearly interpolated height, clamped to the map edge.
    pub fn height_bilinear(&self, x: f64, y: f64) -> f64 {
        let (fx, fy) = self.grid_coords(x, y);
        let fx = fx.clamp(0.0, (self.nx - 1) as f64);
        let fy = fy.clamp(0.0, (self.ny - 1) as f64);
        // fx, fy >= 0 here, so truncation is floor (and avoids a libm call on baseline x86-64).
        let ix = (fx as usize).min(self.nx - 2);
        let iy = (fy as usize).min(self.ny - 2);
        let tx = fx - ix as f64;
        let ty = fy - iy as f64;
        let h00 = self.at(ix, iy);
        let h10 = self.at(ix + 1, iy);
        let h01 = self.at(ix, iy + 1);
        let h11 = self.at(ix + 1, iy + 1);
        (h00 * (1.0 - tx) + h10 * tx) * (1.0 - ty) + (h01 * (1.0 - tx) + h11 * tx) * ty
    }
    /// Unit normal of the bilinear surface (central differences over half a cell each way).
    pub fn surface_normal(&self, x: f64, y: f64) -> nalgebra::Vector3<f64> {
        let e = 0.5 * self.cell;
        let gx = (self.height_bilinear(x + e, y) - self.height_bilinear(x - e, y)) / (2.0 * e);
        let gy = (self.height_bilinear(x, y + e) - self.height_bilinear(x, y - e)) / (2.0 * e);
        nalgebra::Vector3::new(-gx, -gy, 1.0).normalize()
    }

    /// Returns a copy with every length multiplied by `s`.
    pub fn scaled(&self, s: f64) -> Heightmap {
        Heightmap {
            nx: self.nx,
            ny: self.ny,
            cell: self.cell * s,
            heights: self
                .heights
                .iter()
                .map(|h| (*h as f64 * s) as f32)
                .collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_neighbours_stay_on_the_grid_with_diagonal_steps_of_sqrt_2() {
        let h = Heightmap::from_fn(1.0, |_, _| 0.0);
        let n = h.nx;
        // Interior sample: all 8, in the fixed order E, W, N, S, NE, SE, NW, SW.
        let i = 5 * n + 7;
        let got: Vec<(usize, f64)> = h.grid_neighbours(i).collect();
        let r2 = std::f64::consts::SQRT_2;
        assert_eq!(
            got,
            vec![
                (i + 1, 1.0),
                (i - 1, 1.0),
                (i + n, 1.0),
                (i - n, 1.0),
                (i + n + 1, r2),
                (i - n + 1, r2),
                (i + n - 1, r2),
                (i - n - 1, r2),
            ]
        );
        // Corners have three neighbours, edges five; every neighbour is adjacent and on the grid.
        assert_eq!(h.grid_neighbours(0).count(), 3);
        assert_eq!(h.grid_neighbours(n * n - 1).count(), 3);
        assert_eq!(h.grid_neighbours(n / 2).count(), 5);
        for (q, step) in h.grid_neighbours(n - 1) {
            assert!(q < n * n);
            let (dx, dy) = ((q % n).abs_diff(n - 1), q / n);
            assert!(dx <= 1 && dy <= 1);
            assert_eq!(step, if dx == 1 && dy == 1 { r2 } else { 1.0 });
        }
    }
}
