//! Contact geometry: which nodes a rigid wheel or a flat plate presses, the body's surface normal and velocity there,
//! and the fraction of each node's cell the body covers (step 1 of the module's algorithm).

use super::node::{bristle_over_janosi, Hit, RimPoint, BRISTLE_AT_REST};
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

/// Bekker's `b` of a contact patch as Chrono's SCM computes it, `2 A / P` of the hull of the nodes the body's rays
/// hit, for a hull `length x width` (a rectangle: `L W / (L + W)`); `f64::INFINITY` (no `k_c` term, as Chrono's
/// `oob = 0`) when the hull has no area.
#[inline]
fn patch_b(length: f64, width: f64) -> f64 {
    if length <= 0.0 || width <= 0.0 {
        f64::INFINITY
    } else {
        length * width / (length + width)
    }
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
    /// along the axle) is pressed by the rim point above it, as Chrono's SCM: the pressure acts along the
    /// undeformed terrain's normal at the node (vertical on level ground) over the cell's horizontal area, the shear
    /// in the terrain's plane, so compacting the soil costs the wheel torque (the moment of the pressure on its
    /// leading arc about the axle), not drawbar pull. Nodes at the wheel's sides count for the fraction of their cell
    /// inside the width, so the discrete contact width is `b` wherever the wheel is. Bekker's `b` is the patch's, as
    /// Chrono computes it ([`patch_b`]): the hull of the nodes whose rays hit the wheel up to Chrono's test height
    /// (0.1 m) above the surface, on average `delta` shorter than the chord and narrower than the wheel on the grid.
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
        let (vf, vz) = (w.velocity.dot(&fwd), w.velocity.z);
        // The patch's Bekker width: rays hit the rim where it is less than Chrono's test height above the surface
        // of the nodes there, which ahead of the wheel is the surface it meets and behind it the rut it leaves
        // (each taken a radius from the centre, beyond the contact).
        let half_chord = |sign: f64| {
            let at = w.centre + fwd * (sign * w.radius);
            let above = w.centre.z - self.surface_height(at.x, at.y) - self.test_height;
            if above <= 0.0 {
                w.radius
            } else if above < w.radius {
                (w.radius * w.radius - above * above).sqrt()
            } else {
                0.0
            }
        };
        let chord = half_chord(1.0) + half_chord(-1.0);
        let b = patch_b(chord - self.delta, w.width - self.delta);
        let speed = (w.velocity - out.normal_dir * w.velocity.dot(&out.normal_dir))
            .norm()
            .max(w.angular_velocity.dot(&w.axle).abs() * w.radius);
        let bristle = bristle_over_janosi(speed, self.creep_speed);
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
                let (ground, normal) = self.ground.at(&self.world.heightmap, j * self.nx + i, x, y);
                // The rim point over the fixed node falls at `v_z - u v_f / h` (the rim's advance included).
                let approach = normal.z * (u * vf / h - vz);
                let hit = Hit {
                    p,
                    v: w.velocity + w.angular_velocity.cross(&(p - w.centre)),
                    normal,
                    ground,
                    heading: fwd,
                    approach,
                    axle: w.axle,
                    bristle,
                    weight,
                    swept_bottom: ((u < 0.0) != (u + advance < 0.0))
                        .then_some(w.centre.z - w.radius),
                    rim: Some(RimPoint {
                        offset: u,
                        height: h,
                        radius: w.radius,
                        forward: fwd,
                        lateral: side * d.dot(&side),
                        centre_velocity: w.velocity,
                        angular_velocity: w.angular_velocity,
                    }),
                };
                self.press_node((i, j), &hit, b, &w.centre, dt, &mut out);
            }
        }
        if out.nodes > 0 {
            // The wheel's sinkage is its rim's depth below the undeformed surface under the centre, normal to that
            // surface (Wong's z0), not the deepest node's: nodes 0.1 m apart miss the rim's lowest point by up to
            // u^2 / 2r, 3 mm on a HMMWV wheel, a quarter of its static sinkage on sand.
            let h0 = self.world.heightmap.height_bilinear(w.centre.x, w.centre.y);
            out.sinkage = (w.radius - (w.centre.z - h0) * out.normal_dir.z).max(0.0);
        }
        out
    }

    /// Soil force on a flat rectangular plate (a track shoe or belt segment), updating the soil's memory. The
    /// plate's lower face is the plane through `centre` with normal `plate.up`; nodes whose vertical ray meets the
    /// face inside the `length x width` rectangle (grown by half a cell, edge nodes weighted by the fraction of their
    /// cell inside) are pressed. As for a wheel, the pressure acts along the undeformed terrain's normal over the
    /// cell's horizontal area and the shear in the terrain's plane. The Bekker width is the plate's smaller side (a
    /// track's shoes on the ground form one long patch in Chrono, whose `2 A / P` is about the track's width).
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
        let bristle = BRISTLE_AT_REST;
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
                let v = plate.velocity + plate.angular_velocity.cross(&d);
                let (_, normal) = self.ground.at(&self.world.heightmap, j * self.nx + i, x, y);
                let p = plate.centre + d;
                let hit = Hit {
                    p,
                    v,
                    normal,
                    // Under the face point, which rounds a little away from the node (r6's value, kept bit for bit).
                    ground: self.world.heightmap.height_bilinear(p.x, p.y),
                    heading: plate.forward,
                    // The face over a fixed node moves down at `-v . up / up_z`.
                    approach: normal.z * (-v.dot(&plate.up) / plate.up.z),
                    axle: Vector3::zeros(),
                    bristle,
                    weight,
                    swept_bottom: None,
                    rim: None,
                };
                self.press_node((i, j), &hit, b, &plate.centre, dt, &mut out);
            }
        }
        out
    }
}
