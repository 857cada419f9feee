//! Oriented box (a chassis) against obstacles: one contact per touching obstacle, analytic, no allocation.
//!
//! - Rock (an oriented box): separating-axis test over the 15 axes of two boxes; the axis of least overlap gives
//!   the normal and depth. The contact point is the deepest vertex of the box that owns the other face (the
//!   chassis' vertex for a rock face, the rock's vertex for a chassis face); for an edge-edge axis it is the
//!   chassis' support vertex, an approximation good to the depth.
//! - Tree (a vertical cylinder of radius r): the closest point of the trunk axis to the box is found by a
//!   golden-section search (the distance from a segment to a convex set is convex along it); a contact exists
//!   when it is within r horizontally and between the trunk's base and top (flat top). If the axis passes through the box, the least horizontal overlap over the box's two
//!   horizontal axes and the centre direction gives normal and depth.
//!
//! Normals are outward normals of the obstacle (they push the box away); depths are positive.

use super::ObstacleContact;
use crate::world::{Obstacle, ObstacleKind};
use nalgebra::{Matrix3, Vector3};

/// An oriented box: centre, rotation (columns are the box's axes in the world) and half sizes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientedBox {
    pub centre: Vector3<f64>,
    pub rotation: Matrix3<f64>,
    pub half: Vector3<f64>,
}

impl OrientedBox {
    /// Closest point of the box to `p`.
    pub fn closest_point(&self, p: &Vector3<f64>) -> Vector3<f64> {
        let l = self.rotation.transpose() * (p - self.centre);
        let q = Vector3::new(
            l.x.clamp(-self.half.x, self.half.x),
            l.y.clamp(-self.half.y, self.half.y),
            l.z.clamp(-self.half.z, self.half.z),
        );
        self.centre + self.rotation * q
    }

    /// Half length of the box's projection on unit axis `n`.
    fn radius_along(&self, n: &Vector3<f64>) -> f64 {
        (0..3)
            .map(|i| self.half[i] * self.rotation.column(i).dot(n).abs())
            .sum()
    }

    /// Vertex of the box furthest along `n`.
    fn support(&self, n: &Vector3<f64>) -> Vector3<f64> {
        let mut p = self.centre;
        for i in 0..3 {
            let a = self.rotation.column(i).into_owned();
            p += a * self.half[i] * a.dot(n).signum();
        }
        p
    }
}

/// The rock as an [`OrientedBox`].
fn rock_box(o: &Obstacle, (s, c): (f64, f64)) -> OrientedBox {
    OrientedBox {
        centre: Vector3::new(o.x, o.y, o.z + o.half_extents[2]),
        rotation: Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0),
        half: Vector3::new(o.half_extents[0], o.half_extents[1], o.half_extents[2]),
    }
}

/// Contact of a box with one obstacle (`yaw_sc` = sin and cos of its yaw), or `None`.
pub fn box_obstacle(o: &Obstacle, yaw_sc: (f64, f64), b: &OrientedBox) -> Option<ObstacleContact> {
    match o.kind {
        ObstacleKind::Rock => box_rock(&rock_box(o, yaw_sc), b),
        ObstacleKind::Tree => box_tree(o, b),
    }
}

fn box_rock(rock: &OrientedBox, b: &OrientedBox) -> Option<ObstacleContact> {
    let d = b.centre - rock.centre;
    let mut best: Option<(f64, Vector3<f64>, u8)> = None;
    let mut test = |axis: Vector3<f64>, owner: u8| -> bool {
        let len = axis.norm();
        if len < 1e-9 {
            return true; // parallel edges: covered by the face axes
        }
        let n = axis / len;
        let overlap = rock.radius_along(&n) + b.radius_along(&n) - d.dot(&n).abs();
        if overlap <= 0.0 {
            return false;
        }
        // Prefer face axes on near ties (edge axes are only picked when clearly smaller).
        let biased = if owner == 2 {
            overlap * 1.0001 + 1e-9
        } else {
            overlap
        };
        if best.is_none_or(|(o, _, _)| biased < o) {
            let n = if d.dot(&n) < 0.0 { -n } else { n };
            best = Some((biased, n, owner));
        }
        true
    };
    for i in 0..3 {
        if !test(rock.rotation.column(i).into_owned(), 0) {
            return None;
        }
    }
    for i in 0..3 {
        if !test(b.rotation.column(i).into_owned(), 1) {
            return None;
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            let axis = rock.rotation.column(i).cross(&b.rotation.column(j));
            if !test(axis, 2) {
                return None;
            }
        }
    }
    let (_, n, owner) = best?;
    let depth = rock.radius_along(&n) + b.radius_along(&n) - d.dot(&n).abs();
    let point = match owner {
        // The rock's vertex deepest into the chassis face.
        1 => rock.support(&n),
        // The chassis vertex deepest into the rock, moved back onto the rock's surface.
        _ => b.support(&-n) + n * depth,
    };
    Some(ObstacleContact {
        depth,
        normal: n,
        point,
        obstacle: 0,
    })
}

fn box_tree(o: &Obstacle, b: &OrientedBox) -> Option<ObstacleContact> {
    let r = o.half_extents[0];
    let height = 2.0 * o.half_extents[2];
    let axis_at = |t: f64| Vector3::new(o.x, o.y, o.z + t);
    // Quick reject: horizontal distance beyond the box's bounding radius plus r.
    let reach = b.half.norm() + r;
    if (b.centre.x - o.x).hypot(b.centre.y - o.y) > reach
        || b.centre.z + reach < o.z
        || b.centre.z - reach > o.z + height
    {
        return None;
    }
    let dist2 = |t: f64| {
        let p = axis_at(t);
        (b.closest_point(&p) - p).norm_squared()
    };
    // Golden-section search of the closest axis point (48 iterations shrink the interval below 1e-9 of height).
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0, height);
    let (mut t1, mut t2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (dist2(t1), dist2(t2));
    for _ in 0..48 {
        if f1 <= f2 {
            hi = t2;
            (t2, f2) = (t1, f1);
            t1 = hi - g * (hi - lo);
            f1 = dist2(t1);
        } else {
            lo = t1;
            (t1, f1) = (t2, f2);
            t2 = lo + g * (hi - lo);
            f2 = dist2(t2);
        }
    }
    let t = 0.5 * (lo + hi);
    let a = axis_at(t);
    let q = b.closest_point(&a);
    let dh = Vector3::new(q.x - a.x, q.y - a.y, 0.0);
    let dist = dh.norm();
    // The trunk is flat-topped: a box whose closest point lies above the top (or below the base) does not touch.
    if dist >= r || q.z > o.z + height || q.z < o.z {
        return None;
    }
    if dist > 1e-9 {
        // Box outside the trunk's axis: radial contact.
        let n = dh / dist;
        return Some(ObstacleContact {
            depth: r - dist,
            normal: n,
            point: a + n * r,
            obstacle: 0,
        });
    }
    // The axis passes through the box: least horizontal overlap.
    let to_box = Vector3::new(b.centre.x - o.x, b.centre.y - o.y, 0.0);
    let mut best: Option<(f64, Vector3<f64>)> = None;
    for cand in [
        to_box,
        b.rotation.column(0).into_owned(),
        b.rotation.column(1).into_owned(),
    ] {
        let h = Vector3::new(cand.x, cand.y, 0.0);
        let len = h.norm();
        if len < 1e-9 {
            continue;
        }
        let n = h / len;
        let n = if to_box.dot(&n) < 0.0 { -n } else { n };
        let overlap = r + b.radius_along(&n) - to_box.dot(&n);
        if best.is_none_or(|(o, _)| overlap < o) {
            best = Some((overlap, n));
        }
    }
    let (depth, n) = best.unwrap_or((r, Vector3::x()));
    Some(ObstacleContact {
        depth,
        normal: n,
        point: a + n * r,
        obstacle: 0,
    })
}
