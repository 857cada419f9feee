//! Phase 4, contacts: each wheel's contact with the ground. On rigid patches the rim is sampled against the
//! heightfield (the deepest sample gives the tyre deflection, its radial direction the normal, so a wheel climbs a
//! step); on deformable patches the soil grid computes the wheel's force ([`crate::soil::SoilGrid`]).

use super::dynamics::DynamicsState;
use super::params::VehicleParams;
use super::scratch::WheelContact;
use super::simulation::*;
use super::step::Frame;
use crate::soil::WheelGeometry;
use crate::world::{Heightmap, Surface, World};
use nalgebra::Vector3;

/// Phase 4: finds every wheel's contact into `contacts` (updating the wheels' tyre deflection and rut state and the
/// soil under them).
pub(super) fn find_contacts(
    p: &VehicleParams,
    world: &World,
    s: &mut DynamicsState,
    contacts: &mut [WheelContact],
    frame: &Frame,
) {
    for (k, contact) in contacts.iter_mut().enumerate() {
        *contact = wheel_contact(p, world, s, k, &frame.up, &frame.fwd, &frame.omega_w);
    }
}

/// Coulomb friction of the chassis against the ground of `world` at `(x, y)`.
pub(super) fn patch_mu(p: &VehicleParams, world: &World, x: f64, y: f64) -> f64 {
    match world.patch_at(x, y).surface {
        Surface::Rigid { friction } => friction.min(p.tyre_mu),
        Surface::Deformable { soil } => soil.friction_angle_deg.to_radians().tan(),
    }
}

/// The rim's deepest point in rigid ground: its depth below the surface, the contact point and its rim angle (0
/// under the centre). The deepest rim angle wins; across the tread its contact point is the depth-weighted mean of
/// the lateral samples, so a wheel on flat ground touches under its mid-plane (left and right wheels mirror each
/// other).
fn deepest_rim_point(
    h: &Heightmap,
    p: &VehicleParams,
    centre: Vector3<f64>,
    heading: Vector3<f64>,
    axle: Vector3<f64>,
    up: &Vector3<f64>,
) -> (f64, Vector3<f64>, f64) {
    let mut best = (0.0, Vector3::zeros(), 0.0);
    for (a, &(sin, cos)) in RIM_SIN_COS.iter().enumerate() {
        let rim = centre + (heading * sin - up * cos) * p.radius;
        let (mut deepest, mut weight, mut weighted) = (0.0_f64, 0.0, Vector3::zeros());
        for lat in RIM_LATERAL {
            let q = rim + axle * (lat * 0.5 * p.width);
            let depth = (h.height_bilinear(q.x, q.y) - q.z) * cos;
            if depth > 0.0 {
                deepest = deepest.max(depth);
                weight += depth;
                weighted += q * depth;
            }
        }
        if deepest > best.0 {
            best = (deepest, weighted / weight, RIM_ANGLES[a]);
        }
    }
    best
}

/// Wheel `k`'s contact with the soil under its centre (SCM over the wheel's rim, [`crate::soil`]): the wheel
/// centre at `centre`, rolling along `heading` about `axle`.
fn soil_contact(
    p: &VehicleParams,
    s: &mut DynamicsState,
    k: usize,
    (centre, heading, axle): (Vector3<f64>, Vector3<f64>, Vector3<f64>),
    up: &Vector3<f64>,
    omega_w: &Vector3<f64>,
) -> WheelContact {
    let w = &s.wheels[k];
    // The wheel centre moves with the chassis and along the strut (its own vertical DOF).
    let vel = s.vel + omega_w.cross(&(centre - s.pos)) + up * w.compression_rate;
    let spin_vec = axle * w.spin + omega_w;
    let sc = s.soil.wheel_contact(
        &WheelGeometry {
            centre,
            axle,
            radius: p.radius,
            width: p.width,
            velocity: vel,
            angular_velocity: spin_vec,
        },
        p.dt,
    );
    // Sunk in soil, the wheel sits below the nominal surface; if it rolls onto a rigid patch it must climb out.
    let wm = &mut s.wheels[k];
    wm.deflection = 0.0;
    wm.from_soil = true;
    wm.rut_offset = 0.0;
    if sc.nodes == 0 {
        return WheelContact::default();
    }
    let n = sc.normal_dir;
    let tx = (heading - n * heading.dot(&n)).normalize();
    let ty = n.cross(&tx);
    let point = centre - n * p.radius;
    WheelContact {
        active: true,
        soil: true,
        point,
        normal: n,
        load: sc.normal,
        sinkage: sc.sinkage,
        // The soil's vertical Jacobians (elastic or Bekker tangent per node, on the branch it moves along;
        // damping R): the wheel's vertical DOF is implicit in them, so the soil's elastic stiffness is stable
        // at the vehicle's step.
        k_normal: sc.normal_stiffness,
        c_normal: sc.normal_damping,
        mu: 0.0,
        tx,
        ty,
        // The soil acts on the spin through its moment about the axle (Chrono charges the wheel with the
        // full moment of every node force about the spindle): compaction and damping cost engine torque.
        soil_force: sc.force,
        soil_stiffness: sc.traction_stiffness,
        soil_torque: sc.torque.dot(&axle),
        spin_stiffness: sc.spin_stiffness,
        spin_force: sc.spin_force,
        spin_lift: sc.spin_lift,
        soil_moment: sc.torque,
        shear_capacity: sc.shear_capacity,
        r_eff: p.radius,
    }
}

/// Finds the contact of wheel `k` with the ground (rigid or soil) and its tyre deflection force. `omega_w` is the
/// chassis' angular velocity in the world frame, as `step` already has it.
fn wheel_contact(
    p: &VehicleParams,
    world: &World,
    s: &mut DynamicsState,
    k: usize,
    up: &Vector3<f64>,
    fwd_body: &Vector3<f64>,
    omega_w: &Vector3<f64>,
) -> WheelContact {
    let w = &s.wheels[k];
    let centre = s.pos + s.rot * p.wheels[k].centre_offset(w.compression);
    // Rotate the body's forward axis about its up axis by the steering angle (Rodrigues; up is a unit vector
    // perpendicular to fwd).
    let heading = if w.steer_angle == 0.0 {
        *fwd_body
    } else {
        let (sin, cos) = w.steer_angle.sin_cos();
        fwd_body * cos + up.cross(fwd_body) * sin
    };
    let axle = up.cross(&heading).normalize();
    let h = &world.heightmap;
    if s.soil.soil_at(centre.x, centre.y).is_some() {
        return soil_contact(p, s, k, (centre, heading, axle), up, omega_w);
    }
    let best = deepest_rim_point(h, p, centre, heading, axle, up);
    let wm = &mut s.wheels[k];
    // A wheel sunk in soil sits below the nominal surface, so when its centre crosses onto a rigid patch the
    // rigid ground is suddenly up to its sinkage above the rim bottom (the heightmap has no step there; only the
    // soil sank). Taken at face value the stiff tyre (1 cm static deflection) would fire the wheel out of the
    // ground like a catapult. Instead the wheel climbs out of its rut: the ground under it starts at the wheel's
    // sinkage below the rigid surface and rises as the wheel rolls on, RUT_EXIT_SLOPE metres per metre, as if
    // the rut's end were a ramp of soil.
    if wm.from_soil {
        wm.from_soil = false;
        wm.rut_offset = (best.0 - TYRE_STATIC_DEFLECTION * p.spec.scale).max(0.0);
        wm.deflection = best.0 - wm.rut_offset;
    }
    if wm.rut_offset > 0.0 {
        let v = s.vel + omega_w.cross(&(centre - s.pos));
        wm.rut_offset = (wm.rut_offset - v.xy().norm() * p.dt * RUT_EXIT_SLOPE).max(0.0);
    }
    let depth = best.0 - wm.rut_offset;
    if depth <= 0.0 {
        wm.deflection = 0.0;
        return WheelContact::default();
    }
    let (point, ang) = (best.1, best.2);
    let mut normal = (centre + axle * (point - centre).dot(&axle) - point).normalize();
    if ang == 0.0 {
        // Flat contact under the centre: the terrain normal is better conditioned than the radial one.
        normal = h.surface_normal(point.x, point.y);
    }
    let rate = (depth - wm.deflection) / p.dt;
    wm.deflection = depth;
    let load = (p.tyre_k * depth + p.tyre_c * rate).max(0.0);
    let tx = (heading - normal * heading.dot(&normal)).normalize();
    let ty = normal.cross(&tx);
    let mu = match world.patch_at(point.x, point.y).surface {
        Surface::Rigid { friction } => friction.min(p.tyre_mu),
        Surface::Deformable { .. } => p.tyre_mu,
    };
    WheelContact {
        active: true,
        soil: false,
        point,
        normal,
        load,
        sinkage: depth,
        k_normal: p.tyre_k,
        c_normal: p.tyre_c,
        mu,
        tx,
        ty,
        soil_force: Vector3::zeros(),
        soil_stiffness: 0.0,
        soil_torque: 0.0,
        spin_stiffness: 0.0,
        spin_force: 0.0,
        spin_lift: 0.0,
        soil_moment: Vector3::zeros(),
        shear_capacity: 0.0,
        r_eff: (p.radius - depth).max(0.5 * p.radius),
    }
}
