//! Phase 8, body contacts: points on the chassis box (bottom, edges, top) against the heightfield (high-centring,
//! bottoming out, rollover), and the body points and wheel spheres against rocks and trees ([`crate::collide`]).
//! Penalty contacts with damping and regularised Coulomb friction.

use super::contact::patch_mu;
use super::dynamics::DynamicsState;
use super::params::VehicleParams;
use super::simulation::*;
use super::step::{Frame, Wrench};
use crate::collide::ObstacleSet;
use crate::world::World;
use nalgebra::Vector3;

/// Phase 8: see the module docs. Returns whether any part of the vehicle touches an obstacle.
pub(super) fn body_contacts(
    p: &VehicleParams,
    world: &World,
    obstacles: &ObstacleSet,
    s: &DynamicsState,
    frame: &Frame,
    wrench: &mut Wrench,
) -> bool {
    let mut touched = false;
    // Chassis-ground and chassis-obstacle contacts.
    let ground_mu = patch_mu(p, world, s.pos.x, s.pos.y);
    let rot_m = s.rot.to_rotation_matrix();
    let body_radius = 0.5
        * p.spec.chassis.size[0]
            .hypot(p.spec.chassis.size[1])
            .hypot(p.spec.chassis.size[2])
        + p.radius;
    let obstacles_close = obstacles.any_within_in(&s.near, s.pos.x, s.pos.y, body_radius);
    let hm = &world.heightmap;
    let blocks_y = p.block_max.len() / p.blocks_x.max(1);
    for bp in &p.body_points {
        let pw = s.pos + rot_m * bp;
        let v = s.vel + frame.omega_w.cross(&(pw - s.pos));
        let (fx, fy) = hm.grid_coords(pw.x, pw.y);
        let bx = ((fx.max(0.0) as usize) / 4).min(p.blocks_x - 1);
        let by = ((fy.max(0.0) as usize) / 4).min(blocks_y - 1);
        let depth = if pw.z > p.block_max[by * p.blocks_x + bx] {
            -1.0
        } else {
            hm.height_bilinear(pw.x, pw.y) - pw.z
        };
        if depth > 0.0 {
            let n = world.heightmap.surface_normal(pw.x, pw.y);
            let vn = v.dot(&n);
            let fnrm = (p.body_k * depth - p.body_c * vn).max(0.0);
            let vt = v - n * vn;
            let vtn = vt.norm();
            let ft = if vtn > 1e-9 {
                -vt / vtn.max(BODY_FRICTION_SPEED * p.spec.scale.sqrt()) * ground_mu * fnrm
            } else {
                Vector3::zeros()
            };
            let f = n * fnrm + ft;
            wrench.force += f;
            wrench.torque += (pw - s.pos).cross(&f);
        }
        if let Some(oc) = obstacles_close
            .then(|| obstacles.sphere_contact_in(&s.near, &pw, 0.0))
            .flatten()
        {
            let vn = v.dot(&oc.normal);
            let fnrm = (p.obstacle_k * oc.depth
                - 2.0 * OBSTACLE_DAMPING_RATIO * (p.obstacle_k * p.mass).sqrt() * vn.min(0.0))
            .max(0.0);
            let vt = v - oc.normal * vn;
            let vtn = vt.norm();
            let ft = if vtn > 1e-9 {
                -vt / vtn.max(BODY_FRICTION_SPEED) * OBSTACLE_FRICTION * fnrm
            } else {
                Vector3::zeros()
            };
            let f = oc.normal * fnrm + ft;
            wrench.force += f;
            wrench.torque += (pw - s.pos).cross(&f);
            touched = true;
        }
    }
    for k in 0..p.wheels.len() {
        let centre = s.pos + s.rot * p.wheels[k].centre_offset(s.wheels[k].compression);
        if let Some(oc) = obstacles_close
            .then(|| obstacles.sphere_contact_in(&s.near, &centre, p.radius))
            .flatten()
        {
            let v = s.vel + frame.omega_w.cross(&(centre - s.pos));
            let vn = v.dot(&oc.normal);
            let fnrm = (p.obstacle_k * oc.depth
                - 2.0 * OBSTACLE_DAMPING_RATIO * (p.obstacle_k * p.mass).sqrt() * vn.min(0.0))
            .max(0.0);
            let f = oc.normal * fnrm;
            wrench.force += f;
            wrench.torque += (centre - s.pos).cross(&f);
            touched = true;
        }
    }
    touched
}
