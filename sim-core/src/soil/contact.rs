//! Contact geometry: which nodes a rigid wheel or a flat plate presses, the body's surface normal and velocity there,
//! and the fraction of each node's cell the body covers (step 1 of the module's algorithm).

use super::node::{Hit, RimPoint};
use super::{PlateGeometry, SoilContact, SoilGrid, WheelGeometry};
use nalgebra::Vector3;

/// Fraction of a node's cell (side `delta`, centred at offset `a` from a body's centre line) covered by a body
/// strip `|a| <= half`: 1 inside, 0 outside, linear across the cell at the edge. Summed over a row of nodes it gives
/// the body's width exactly (as long as the strip is wider than a cell), wherever the body lies on the grid.
#[inline]
fn coverage(a: f64, half: f64, delta: f64) -> f64 {
    let f = ((half - a.abs()) / delta + 0.5).min(1.0);
    // Rounding of a node exactly on the edge of the grown strip counts as outside.
    if f < 1e-9 {
        0.0
    } else {
        f
    }
}

/// A body's sinking motion ([`Hit::compaction_velocity`]): the part of its velocity `v` along the ground's unit
/// normal `n` while it moves into the soil, else zero.
#[inline]
fn sinking(v: &Vector3<f64>, n: &Vector3<f64>) -> Vector3<f64> {
    n * v.dot(n).min(0.0)
}

impl SoilGrid {
    /// Node index range covering `[c.x - rx, c.x + rx] x [c.y - ry, c.y + ry]` (inclusive).
    fn node_box(&self, c: &Vector3<f64>, rx: f64, ry: f64) -> (usize, usize, usize, usize) {
        let lo = |v: f64, half: f64| ((v + half) / self.delta).floor().max(0.0) as usize;
        let hi = |v: f64, half: f64, n: usize| {
            (((v + half) / self.delta).ceil().max(0.0) as usize).min(n - 1)
        };
        (
            lo(c.x - rx, self.half_x),
            hi(c.x + rx, self.half_x, self.nx),
            lo(c.y - ry, self.half_y),
            hi(c.y + ry, self.half_y, self.ny),
        )
    }

    /// Soil force on a rigid wheel (a cylinder with a horizontal axle), updating the soil's memory. Nodes on rigid
    /// patches are skipped.
    ///
    /// Each node whose vertical ray meets the rim (`|u| < r` along the wheel's heading, `|a| < b / 2 + delta / 2`
    /// along the axle) is pressed by the rim point above it; the pressure acts along the rim's inward radial
    /// direction there (the wheel's surface normal, as Chrono's SCM uses the normals of its ray hits), so the
    /// leading arc of a sinking wheel pushes it back (compaction resistance). Nodes at the wheel's sides count for
    /// the fraction of their cell inside the width, so the discrete contact width is `b` wherever the wheel is.
    pub fn wheel_contact(&mut self, w: &WheelGeometry, dt: f64) -> SoilContact {
        let mut out = SoilContact::default();
        if self.tile_index.is_empty() {
            return out;
        }
        out.normal_dir = self.surface_normal(w.centre.x, w.centre.y);
        let mut fwd = Vector3::z().cross(&w.axle);
        let fwd_norm = fwd.norm();
        if fwd_norm < 1e-9 {
            return out;
        }
        fwd /= fwd_norm;
        let half_b = 0.5 * w.width;
        let reach_b = half_b + 0.5 * self.delta;
        // Horizontal axle direction: the footprint is the rectangle |u| < r, |a| < reach_b.
        let side = Vector3::new(-fwd.y, fwd.x, 0.0);
        let (i0, i1, j0, j1) = self.node_box(
            &w.centre,
            fwd.x.abs() * w.radius + side.x.abs() * reach_b,
            fwd.y.abs() * w.radius + side.y.abs() * reach_b,
        );
        // How far the wheel moved along its heading in this step: a node the lowest rim point passed over
        // (0 between its offsets `u` now and `u + advance` before) is yielded as deep as the rim bottom went, so the
        // ruts do not depend on which of the node's positions under the wheel the steps happen to catch.
        let advance = w.velocity.dot(&fwd) * dt;
        // The centre's sinking velocity (not the rim's spin): the soil under the wheel moves down with it.
        let compaction_velocity = sinking(&w.velocity, &out.normal_dir);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let x = i as f64 * self.delta - self.half_x;
                let y = j as f64 * self.delta - self.half_y;
                let d = Vector3::new(x - w.centre.x, y - w.centre.y, 0.0);
                let a = d.dot(&w.axle);
                let u = d.dot(&fwd);
                let weight = coverage(a, half_b, self.delta);
                if weight == 0.0 || u.abs() >= w.radius {
                    continue;
                }
                let h = (w.radius * w.radius - u * u).sqrt();
                let p = Vector3::new(x, y, w.centre.z - h);
                let normal = Vector3::new(-u * fwd.x, -u * fwd.y, h) / w.radius;
                let hit = Hit {
                    p,
                    v: w.velocity + w.angular_velocity.cross(&(p - w.centre)),
                    normal,
                    roll: w.axle.cross(&normal).normalize(),
                    weight,
                    compaction_velocity,
                    swept_bottom: ((u < 0.0) != (u + advance < 0.0))
                        .then_some(w.centre.z - w.radius),
                    rim: Some(RimPoint {
                        offset: u,
                        height: h,
                        radius: w.radius,
                        forward: fwd,
                        centre_velocity: w.velocity,
                    }),
                };
                self.press_node((i, j), &hit, w.width, &w.centre, dt, &mut out);
            }
        }
        if out.nodes > 0 {
            // The wheel's sinkage is its rim's depth below the undeformed surface under the centre, normal to that
            // surface (Wong's z0), not the deepest node's: nodes 0.1 m apart miss the rim's lowest point by up to
            // u^2 / 2r, 3 mm on a HMMWV wheel, a quarter of its static sinkage on sand.
            let h0 = self.heights.height_bilinear(w.centre.x, w.centre.y);
            out.sinkage = (w.radius - (w.centre.z - h0) * out.normal_dir.z).max(0.0);
        }
        out
    }

    /// Soil force on a flat rectangular plate (a track shoe or belt segment), updating the soil's memory. The
    /// plate's lower face is the plane through `centre` with normal `plate.up`; nodes whose vertical ray meets the
    /// face inside the `length x width` rectangle (grown by half a cell, edge nodes weighted by the fraction of their
    /// cell inside) are pressed. Pressure acts along `plate.up`, shear in the face. The Bekker width is the plate's
    /// smaller side.
    pub fn plate_contact(&mut self, plate: &PlateGeometry, dt: f64) -> SoilContact {
        let mut out = SoilContact::default();
        if self.tile_index.is_empty() || plate.up.z < 1e-3 {
            return out;
        }
        out.normal_dir = self.surface_normal(plate.centre.x, plate.centre.y);
        let side = plate.up.cross(&plate.forward);
        let b = plate.length.min(plate.width);
        let (hl, hw) = (0.5 * plate.length, 0.5 * plate.width);
        let reach = hl.hypot(hw) + self.delta;
        let (i0, i1, j0, j1) = self.node_box(&plate.centre, reach, reach);
        let compaction_velocity = sinking(&plate.velocity, &out.normal_dir);
        for j in j0..=j1 {
            for i in i0..=i1 {
                let x = i as f64 * self.delta - self.half_x;
                let y = j as f64 * self.delta - self.half_y;
                let (dx, dy) = (x - plate.centre.x, y - plate.centre.y);
                // Height of the face above (x, y): on the plane n . (p - c) = 0.
                let dz = -(plate.up.x * dx + plate.up.y * dy) / plate.up.z;
                let d = Vector3::new(dx, dy, dz);
                let weight = coverage(d.dot(&plate.forward), hl, self.delta)
                    * coverage(d.dot(&side), hw, self.delta);
                if weight == 0.0 {
                    continue;
                }
                let hit = Hit {
                    p: plate.centre + d,
                    v: plate.velocity + plate.angular_velocity.cross(&d),
                    normal: plate.up,
                    roll: plate.forward,
                    weight,
                    compaction_velocity,
                    swept_bottom: None,
                    rim: None,
                };
                self.press_node((i, j), &hit, b, &plate.centre, dt, &mut out);
            }
        }
        out
    }
}
