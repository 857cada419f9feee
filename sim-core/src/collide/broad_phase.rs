//! Uniform-grid broad phase over the obstacles' horizontal bounding circles, built once per world.
//!
//! Cells are [`CELL`] m square (coarser if the obstacles spread over more than 4 km; the cell size only trades
//! memory for candidates) over the bounding rectangle of all obstacles; each cell lists, in id order, the obstacles whose
//! bounding circle overlaps it (compressed rows: `starts` and `items`). A query walks the cells overlapping a
//! disc and writes candidate ids into a caller-provided slice, skipping duplicates with a per-obstacle stamp kept by
//! the caller ([`QueryStamps`]: the grid itself is immutable and shared); no allocation per query.

/// Cell side, m.
pub const CELL: f64 = 4.0;

/// The grid.
#[derive(Clone, Debug)]
pub struct ObstacleGrid {
    x0: f64,
    y0: f64,
    cell: f64,
    nx: usize,
    ny: usize,
    /// `items[starts[c]..starts[c + 1]]` are the obstacles of cell `c = iy * nx + ix`.
    starts: Vec<u32>,
    items: Vec<u32>,
}

/// The query stamp of each obstacle (duplicate suppression), the mutable half of a query: one per user of a grid.
#[derive(Clone, Debug)]
pub struct QueryStamps {
    stamp: Vec<u32>,
    query: u32,
}

impl QueryStamps {
    /// Stamps for `n` obstacles (allocates once).
    pub fn new(n: usize) -> QueryStamps {
        QueryStamps {
            stamp: vec![0; n],
            query: 0,
        }
    }
}

impl ObstacleGrid {
    /// Builds the grid from the obstacles' centres `(x, y)` and bounding radii.
    pub fn new(centres: &[(f64, f64)], radii: &[f64]) -> ObstacleGrid {
        let (mut x0, mut y0, mut x1, mut y1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for (k, &(x, y)) in centres.iter().enumerate() {
            let r = radii[k];
            if k == 0 {
                (x0, y0, x1, y1) = (x - r, y - r, x + r, y + r);
            }
            x0 = x0.min(x - r);
            y0 = y0.min(y - r);
            x1 = x1.max(x + r);
            y1 = y1.max(y + r);
        }
        // At most 1024 cells a side: huge extents get coarser cells rather than a huge allocation.
        let cell = CELL.max((x1 - x0) / 1024.0).max((y1 - y0) / 1024.0);
        // Non-finite extents (bad input; such obstacles never pass the distance filter) collapse to one cell.
        let cell = if cell.is_finite() { cell } else { CELL };
        let span = |a: f64, b: f64| {
            let n = ((b - a) / cell).floor() + 1.0;
            if n.is_finite() && n >= 1.0 {
                (n as usize).min(1025)
            } else {
                1
            }
        };
        let (nx, ny) = (span(x0, x1), span(y0, y1));
        let cell_range = |grid_lo: f64, lo: f64, hi: f64, n: usize| {
            let a = ((lo - grid_lo) / cell).floor().max(0.0) as usize;
            let b = ((hi - grid_lo) / cell).floor().max(0.0) as usize;
            (a.min(n - 1), b.min(n - 1))
        };
        let mut counts = vec![0u32; nx * ny + 1];
        let each = |f: &mut dyn FnMut(usize, usize)| {
            for (k, &(x, y)) in centres.iter().enumerate() {
                let r = radii[k];
                let (ia, ib) = cell_range(x0, x - r, x + r, nx);
                let (ja, jb) = cell_range(y0, y - r, y + r, ny);
                for j in ja..=jb {
                    for i in ia..=ib {
                        f(j * nx + i, k);
                    }
                }
            }
        };
        each(&mut |c, _| counts[c + 1] += 1);
        for c in 0..nx * ny {
            counts[c + 1] += counts[c];
        }
        let starts = counts.clone();
        let mut fill = counts;
        let mut items = vec![0u32; starts[nx * ny] as usize];
        each(&mut |c, k| {
            items[fill[c] as usize] = k as u32;
            fill[c] += 1;
        });
        ObstacleGrid {
            x0,
            y0,
            cell,
            nx,
            ny,
            starts,
            items,
        }
    }

    /// Writes into `out` the ids of the obstacles listed in the cells overlapping the square of half side
    /// `radius` around `(x, y)` (each once, in no particular order; the caller filters and sorts); returns how many
    /// were written (at most `out.len()`).
    /// `stamps` must have been made for this grid's obstacles.
    pub fn candidates(
        &self,
        stamps: &mut QueryStamps,
        x: f64,
        y: f64,
        radius: f64,
        out: &mut [u32],
    ) -> usize {
        if self.items.is_empty() {
            return 0;
        }
        stamps.query = stamps.query.wrapping_add(1);
        if stamps.query == 0 {
            stamps.stamp.iter_mut().for_each(|s| *s = 0);
            stamps.query = 1;
        }
        let range = |lo: f64, hi: f64, origin: f64, n: usize| -> Option<(usize, usize)> {
            let a = ((lo - origin) / self.cell).floor();
            let b = ((hi - origin) / self.cell).floor();
            if !(a.is_finite() && b.is_finite()) || b < 0.0 || a > (n - 1) as f64 {
                return None;
            }
            Some((a.max(0.0) as usize, (b as usize).min(n - 1)))
        };
        let (Some((ia, ib)), Some((ja, jb))) = (
            range(x - radius, x + radius, self.x0, self.nx),
            range(y - radius, y + radius, self.y0, self.ny),
        ) else {
            return 0;
        };
        let mut len = 0;
        for j in ja..=jb {
            for i in ia..=ib {
                let c = j * self.nx + i;
                for &k in &self.items[self.starts[c] as usize..self.starts[c + 1] as usize] {
                    if stamps.stamp[k as usize] != stamps.query && len < out.len() {
                        stamps.stamp[k as usize] = stamps.query;
                        out[len] = k;
                        len += 1;
                    }
                }
            }
        }
        len
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn candidates_are_the_obstacles_of_the_overlapping_cells_each_once() {
        // Obstacle 1 straddles four cells; obstacle 2 is 40 m away.
        let centres = [(0.0, 0.0), (4.0, 4.0), (40.0, 0.0)];
        let radii = [1.0, 2.0, 1.0];
        let g = ObstacleGrid::new(&centres, &radii);
        let mut st = QueryStamps::new(3);
        let mut out = [0u32; 8];
        let n = g.candidates(&mut st, 1.0, 1.0, 2.0, &mut out);
        let mut got = out[..n].to_vec();
        got.sort();
        assert_eq!(got, vec![0, 1]);
        let n = g.candidates(&mut st, 40.0, 0.0, 0.5, &mut out);
        assert_eq!(&out[..n], &[2]);
        assert_eq!(g.candidates(&mut st, -100.0, 0.0, 1.0, &mut out), 0);
        assert_eq!(g.candidates(&mut st, f64::NAN, 0.0, 1.0, &mut out), 0);
        // Obstacles 100 km apart: coarse cells, still found.
        let g = ObstacleGrid::new(&[(0.0, 0.0), (1e5, 1e5)], &[1.0, 1.0]);
        let mut st = QueryStamps::new(2);
        assert_eq!(g.candidates(&mut st, 1e5, 1e5, 1.0, &mut out), 1);
        assert_eq!(out[0], 1);
    }
}
