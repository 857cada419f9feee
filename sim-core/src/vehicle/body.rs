//! Phase 8, body contacts: points on the chassis box (bottom, edges, top) against the heightfield (high-centring,
//! bottoming out, rollover), and the body points and wheel spheres against rocks and trees ([`crate::collide`]).
//! Penalty contacts with damping and regularised Coulomb friction.

use super::simulation::*;
use super::step::{Frame, Wrench};
use nalgebra::Vector3;

impl Simulation {
    /// Phase 8: see the module docs. Returns whether any part of the vehicle touches an obstacle.
    pub(super) fn body_contacts(&mut self, frame: &Frame, wrench: &mut Wrench) -> bool {
        let mut touched = false;
        // Chassis-ground and chassis-obstacle contacts.
        let ground_mu = self.patch_mu(self.pos.x, self.pos.y);
        let rot_m = self.rot.to_rotation_matrix();
        let body_radius = 0.5
            * self.spec.chassis.size[0]
                .hypot(self.spec.chassis.size[1])
                .hypot(self.spec.chassis.size[2])
            + self.radius;
        let obstacles_close = self
            .obstacles
            .any_within(self.pos.x, self.pos.y, body_radius);
        let hm = &self.world_patches.heightmap;
        let blocks_y = self.block_max.len() / self.blocks_x.max(1);
        for p in &self.body_points {
            let pw = self.pos + rot_m * p;
            let v = self.vel + frame.omega_w.cross(&(pw - self.pos));
            let (fx, fy) = hm.grid_coords(pw.x, pw.y);
            let bx = ((fx.max(0.0) as usize) / 4).min(self.blocks_x - 1);
            let by = ((fy.max(0.0) as usize) / 4).min(blocks_y - 1);
            let depth = if pw.z > self.block_max[by * self.blocks_x + bx] {
                -1.0
            } else {
                hm.height_bilinear(pw.x, pw.y) - pw.z
            };
            if depth > 0.0 {
                let n = self.world_patches.heightmap.surface_normal(pw.x, pw.y);
                let vn = v.dot(&n);
                let fnrm = (self.body_k * depth - self.body_c * vn).max(0.0);
                let vt = v - n * vn;
                let vtn = vt.norm();
                let ft = if vtn > 1e-9 {
                    -vt / vtn.max(BODY_FRICTION_SPEED * self.spec.scale.sqrt()) * ground_mu * fnrm
                } else {
                    Vector3::zeros()
                };
                let f = n * fnrm + ft;
                wrench.force += f;
                wrench.torque += (pw - self.pos).cross(&f);
            }
            if let Some(oc) = obstacles_close
                .then(|| self.obstacles.sphere_contact(&pw, 0.0))
                .flatten()
            {
                let vn = v.dot(&oc.normal);
                let fnrm = (self.obstacle_k * oc.depth
                    - 2.0
                        * OBSTACLE_DAMPING_RATIO
                        * (self.obstacle_k * self.mass).sqrt()
                        * vn.min(0.0))
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
                wrench.torque += (pw - self.pos).cross(&f);
                touched = true;
            }
        }
        for k in 0..self.wheels.len() {
            let centre = self.pos + self.rot * self.wheels[k].centre_offset();
            if let Some(oc) = obstacles_close
                .then(|| self.obstacles.sphere_contact(&centre, self.radius))
                .flatten()
            {
                let v = self.vel + frame.omega_w.cross(&(centre - self.pos));
                let vn = v.dot(&oc.normal);
                let fnrm = (self.obstacle_k * oc.depth
                    - 2.0
                        * OBSTACLE_DAMPING_RATIO
                        * (self.obstacle_k * self.mass).sqrt()
                        * vn.min(0.0))
                .max(0.0);
                let f = oc.normal * fnrm;
                wrench.force += f;
                wrench.torque += (centre - self.pos).cross(&f);
                touched = true;
            }
        }
        touched
    }
}
