//! Building a [`Simulation`] from a vehicle spec (wheel layout, spin groups, stiffnesses, body points, the terrain's
//! block maxima) and placing it at rest on the ground.

use super::action::Action;
use super::dynamics::{DynamicsState, Origin, WheelState};
use super::params::{VehicleParams, WheelParams};
use super::powertrain::Clutch;
use super::scratch::StepScratch;
use super::simulation::*;
use crate::collide::{NearList, ObstacleSet};
use crate::soil::SoilGrid;
use crate::vehicle::spec::{Differential, SteeringKind, VehicleSpec};
use crate::world::{Heightmap, World};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use std::sync::Arc;

impl Simulation {
    /// Places the vehicle in `world` at `(x, y)` with heading `yaw`, resting on the ground. Copies the world once
    /// (into the `Arc` the simulation shares); [`Simulation::new_shared`] takes a shared world.
    pub fn new(world: &World, spec: &VehicleSpec, x: f64, y: f64, yaw: f64) -> Simulation {
        Simulation::with_options(world, spec, x, y, yaw, &SimOptions::default())
    }

    /// [`Simulation::new`] in a shared world (no copy of it).
    pub fn new_shared(
        world: Arc<World>,
        spec: &VehicleSpec,
        x: f64,
        y: f64,
        yaw: f64,
    ) -> Simulation {
        Simulation::with_options_shared(world, spec, x, y, yaw, &SimOptions::default())
    }

    /// [`Simulation::new`] with a chosen time step and gravity (convergence studies, tilt tables). A step that is
    /// not finite and positive falls back to [`default_dt`].
    pub fn with_options(
        world: &World,
        spec: &VehicleSpec,
        x: f64,
        y: f64,
        yaw: f64,
        options: &SimOptions,
    ) -> Simulation {
        Simulation::with_options_shared(Arc::new(world.clone()), spec, x, y, yaw, options)
    }

    /// [`Simulation::with_options`] in a shared world (no copy of it).
    pub fn with_options_shared(
        world: Arc<World>,
        spec: &VehicleSpec,
        x: f64,
        y: f64,
        yaw: f64,
        options: &SimOptions,
    ) -> Simulation {
        let scale = spec.scale;
        let dt = options
            .dt
            .filter(|d| d.is_finite() && *d > 0.0)
            .unwrap_or_else(|| default_dt(scale));
        let total = spec.chassis.mass;
        let unsprung = UNSPRUNG_FRACTION * total;
        let (wheels, groups) = wheel_params(spec, unsprung);
        let clutches = clutches(spec, &wheels);
        let n = wheels.len() as f64;
        let sprung = total - n * unsprung;
        let i = spec.chassis.inertia;
        let inertia = Matrix3::from_diagonal(&Vector3::new(i[0], i[1], i[2]));
        let static_load = total * G / n;
        let tyre_k = static_load / (TYRE_STATIC_DEFLECTION * scale);
        let bristle_k = static_load / (BRISTLE_STATIC_DEFLECTION * scale);
        let body_k = total * G / (BODY_CONTACT_DEFLECTION * scale) / 4.0;
        let body_points = body_points(spec);
        let hm = &world.heightmap;
        let (block_max, blocks_x) = block_max(hm);
        let group_inertia = (0..groups)
            .map(|g| {
                spec.wheels.inertia * wheels.iter().filter(|w| w.group == g).count().max(1) as f64
            })
            .collect();
        let scratch = StepScratch::new(groups, clutches.len(), wheels.len());
        let state = DynamicsState {
            time: 0.0,
            pos: Vector3::zeros(),
            rot: UnitQuaternion::identity(),
            vel: Vector3::zeros(),
            omega: Vector3::zeros(),
            gear: 0,
            steering: 0.0,
            accel_prev: Vector3::zeros(),
            steps: 0,
            wheels: vec![WheelState::default(); wheels.len()],
            near: NearList::default(),
            soil: SoilGrid::new(Arc::clone(&world)),
            settle_time: 0.0,
            origin: Origin {
                vehicle: spec.name.clone(),
                grid: (hm.nx, hm.ny, hm.cell),
                obstacles: world.obstacles.len(),
            },
        };
        let params = VehicleParams {
            block_max,
            blocks_x,
            spec: spec.clone(),
            dt,
            mass: sprung,
            total_mass: total,
            inertia,
            inertia_inv: inertia.try_inverse().unwrap_or_else(Matrix3::identity),
            unsprung,
            radius: spec.wheels.radius,
            width: spec.wheels.width,
            wheel_inertia: spec.wheels.inertia,
            tyre_mu: spec.wheels.mu,
            bristle_k,
            bristle_c: 2.0 * BRISTLE_DAMPING_RATIO * (bristle_k * total / n).sqrt(),
            tyre_k,
            tyre_c: 2.0 * TYRE_DAMPING_RATIO * (tyre_k * unsprung).sqrt(),
            body_points,
            body_k,
            body_c: 2.0 * BODY_DAMPING_RATIO * (body_k * total / 4.0).sqrt(),
            obstacle_k: total * G / (OBSTACLE_CONTACT_DEFLECTION * scale),
            groups,
            group_inertia,
            clutches,
            wheels,
        };
        let mut sim = Simulation {
            params,
            obstacles: ObstacleSet::of_world(Arc::clone(&world)),
            world,
            gravity: Vector3::from(options.gravity),
            state,
            scratch,
        };
        sim.place(x, y, yaw);
        sim
    }

    /// Puts the vehicle at rest on the ground at `(x, y)` with heading `yaw`: its pose comes from a plane fitted
    /// over the footprint ([`Simulation::footprint_plane`]; never from single samples, so one pit does not start a
    /// task tilted), the wheels touch it with no spin, raised where a rim sample would start inside rough
    /// ground, and the vehicle then settles with its brakes on ([`Simulation::settle`]), as
    /// the release drops its vehicle onto the ground. Time and step count start at zero afterwards.
    pub fn place(&mut self, x: f64, y: f64, yaw: f64) {
        let (centre_z, rot) = self.footprint_plane(x, y, yaw);
        let (p, s, h) = (&self.params, &mut self.state, &self.world.heightmap);
        s.rot = rot;
        let (up, fwd) = (rot * Vector3::z(), rot * Vector3::x());
        // The wheels hang at full droop (springs unloaded: the weight is ramped up in `settle`) and the lowest rim
        // sample of all just touches the ground.
        s.pos = Vector3::new(x, y, centre_z) + up * (p.radius + p.spec.chassis.com_height);
        for wh in &mut s.wheels {
            wh.compression = 0.0;
            wh.compression_rate = 0.0;
            wh.spin = 0.0;
            wh.bristle = [0.0; 2];
            wh.deflection = 0.0;
            wh.from_soil = false;
            wh.rut_offset = 0.0;
        }
        let axle = up.cross(&fwd);
        let mut raise = f64::NEG_INFINITY;
        for (wp, wh) in p.wheels.iter().zip(&s.wheels) {
            let centre = s.pos + s.rot * wp.centre_offset(wh.compression);
            for &(sin, cos) in &RIM_SIN_COS {
                for lat in RIM_LATERAL {
                    let q =
                        centre + (fwd * sin - up * cos) * p.radius + axle * (lat * 0.5 * p.width);
                    raise = raise.max((h.height_bilinear(q.x, q.y) - q.z) * cos);
                }
            }
        }
        if raise.is_finite() {
            s.pos += up * raise;
        }
        s.vel = Vector3::zeros();
        s.omega = Vector3::zeros();
        s.gear = 0;
        s.steering = 0.0;
        s.accel_prev = Vector3::zeros();
        s.soil.reset();
        self.obstacles.refresh(&mut s.near, x, y, p.reach());
        self.settle();
    }

    /// The least-squares plane through the terrain under the vehicle's footprint (a 5 x 5 grid of samples over the
    /// wheelbase plus a wheel diameter by the track plus a tyre width, heading `yaw`): the plane's height at `(x, y)`
    /// and the orientation whose up axis is the plane's normal and whose forward axis points along `yaw`.
    pub fn footprint_plane(&self, x: f64, y: f64, yaw: f64) -> (f64, UnitQuaternion<f64>) {
        let (p, h) = (&self.params, &self.world.heightmap);
        let half_l = 0.5 * p.spec.wheelbase() + p.radius;
        let half_w = 0.5 * (p.spec.track() + p.width);
        let (c, s) = (yaw.cos(), yaw.sin());
        let (mut sum, mut su, mut sv, mut suu, mut svv) = (0.0, 0.0, 0.0, 0.0, 0.0);
        // Sample k of FOOTPRINT_SAMPLES at -1 .. 1 across the footprint.
        let t = |k: usize| 2.0 * k as f64 / (FOOTPRINT_SAMPLES - 1) as f64 - 1.0;
        for i in 0..FOOTPRINT_SAMPLES {
            for j in 0..FOOTPRINT_SAMPLES {
                let (u, v) = (t(i) * half_l, t(j) * half_w);
                let z = h.height_bilinear(x + u * c - v * s, y + u * s + v * c);
                sum += z;
                su += u * z;
                sv += v * z;
                suu += u * u;
                svv += v * v;
            }
        }
        // On a symmetric grid the normal equations decouple: z = a + b u + d v.
        let a = sum / (FOOTPRINT_SAMPLES * FOOTPRINT_SAMPLES) as f64;
        let (b, d) = (su / suu, sv / svv);
        let (fwd_h, left_h) = (Vector3::new(c, s, 0.0), Vector3::new(-s, c, 0.0));
        let normal = (Vector3::z() - fwd_h * b - left_h * d).normalize();
        let fwd = (fwd_h + Vector3::z() * b).normalize();
        let fwd = (fwd - normal * fwd.dot(&normal)).normalize();
        let left = normal.cross(&fwd);
        let m = nalgebra::Matrix3::from_columns(&[fwd, left, normal]);
        let rot =
            UnitQuaternion::from_rotation_matrix(&nalgebra::Rotation3::from_matrix_unchecked(m));
        (a, rot)
    }

    /// Lets the vehicle come to rest on the ground with its brakes on and no throttle: its weight is applied
    /// gradually (gravity ramped up from zero over [`LOAD_RAMP`], so soft soil yields quasi-statically to its
    /// static sinkage rather than the deeper one of an impact), then it steps until chassis and wheels have been
    /// still (speed below [`SETTLED_SPEED`]) for [`SETTLED_FOR`] seconds, at most [`SETTLE_MAX`] seconds in all
    /// (times scaled by sqrt(scale)). Meanwhile the chassis is held horizontally and its rotation is over-damped
    /// (angular velocity cleared every step), so it sinks vertically and tilts quasi-statically onto the ground. Then time and step count are set back to zero, so an episode starts at rest.
    /// Returns the settling time, s.
    pub fn settle(&mut self) -> f64 {
        let (x, y) = (self.state.pos.x, self.state.pos.y);
        let brake = Action {
            steering: 0.0,
            throttle: 0.0,
            brake: 1.0,
        };
        // Froude similitude: times and speeds scale with sqrt(scale).
        let time_scale = self.params.spec.scale.sqrt();
        let mut still = 0.0;
        self.state.time = 0.0;
        self.state.steps = 0;
        let gravity = self.gravity;
        let ramp = LOAD_RAMP * time_scale;
        while self.state.time < SETTLE_MAX * time_scale
            && (still < SETTLED_FOR * time_scale || self.state.time < ramp)
        {
            // Smoothly (zero rate at both ends), so the ramp's end excites no rocking.
            let t = (self.state.time / ramp).min(1.0);
            self.step_under(gravity * (t * t * (3.0 - 2.0 * t)), &brake);
            // Held as a crane holds a load: the chassis does not move horizontally, and its angular velocity is
            // cleared every step, so it only tilts quasi-statically (one step's rotation at a time) onto the wheels'
            // support. A vehicle placed where it cannot stand (a slope steeper than its friction or tipping angle)
            // is put down there and slides or tips in the episode, not before it.
            let s = &mut self.state;
            s.pos.x = x;
            s.pos.y = y;
            s.vel.x = 0.0;
            s.vel.y = 0.0;
            s.omega = Vector3::zeros();
            // Held horizontally and in rotation, the chassis can only move vertically; the wheels along their struts.
            let moving = s.vel.z.abs().max(
                s.wheels
                    .iter()
                    .map(|w| w.compression_rate.abs())
                    .fold(0.0, f64::max),
            );
            still = if moving < SETTLED_SPEED * time_scale {
                still + self.params.dt
            } else {
                0.0
            };
        }
        let s = &mut self.state;
        s.settle_time = s.time;
        s.time = 0.0;
        s.steps = 0;
        s.gear = 0;
        s.settle_time
    }
}

/// The locking clutches of a clutched driveline: one per driven axle between its wheels, one between the two driven
/// axles (the spec's validation guarantees two driven axles, no tracks, one wheel a side per axle).
fn clutches(spec: &VehicleSpec, wheels: &[WheelParams]) -> Vec<Clutch> {
    let Some(limits) = spec.powertrain.locking_limits else {
        return Vec::new();
    };
    if spec.powertrain.differential != Differential::Clutched {
        return Vec::new();
    }
    let axles: Vec<[usize; 2]> = spec
        .axles
        .iter()
        .enumerate()
        .filter(|(_, a)| a.driven)
        .map(|(ai, _)| [wheels[2 * ai].group, wheels[2 * ai + 1].group])
        .collect();
    let mut out: Vec<Clutch> = axles
        .iter()
        .map(|&[l, r]| Clutch {
            a: [l, l],
            b: [r, r],
            members: 1,
            limit: limits.axle,
        })
        .collect();
    if let [front, rear] = axles[..] {
        out.push(Clutch {
            a: front,
            b: rear,
            members: 2,
            limit: limits.central,
        });
    }
    out
}

/// Every wheel's (or track contact's) parameters, and how many spin groups they form: locked drivelines share one
/// group, skid-steered sides one each, every other wheel its own.
fn wheel_params(spec: &VehicleSpec, unsprung: f64) -> (Vec<WheelParams>, usize) {
    let n_wheels_axle = 2;
    let mut wheels = Vec::new();
    let total = spec.chassis.mass;
    let xs: Vec<f64> = spec.axles.iter().map(|a| a.x).collect();
    let x_front = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let x_rear_ref = {
        let rear: Vec<f64> = spec
            .axles
            .iter()
            .filter(|a| !a.steered)
            .map(|a| a.x)
            .collect();
        if rear.is_empty() {
            xs.iter().copied().fold(f64::INFINITY, f64::min)
        } else {
            rear.iter().sum::<f64>() / rear.len() as f64
        }
    };
    // Static axle loads from the moment balance (two-axle exact; more axles: proportional to 1/|x - x_cg| weights
    // normalised, a documented approximation for the preload reference only).
    let n_axles = spec.axles.len();
    let loads: Vec<f64> = if n_axles == 2 {
        let (a, b) = (spec.axles[0].x, spec.axles[1].x);
        vec![total * G * (-b) / (a - b), total * G * a / (a - b)]
    } else {
        vec![total * G / n_axles as f64; n_axles]
    };
    let skid = spec.steering.kind == SteeringKind::Skid;
    let mut positions: Vec<(usize, f64)> = spec
        .axles
        .iter()
        .enumerate()
        .map(|(ai, a)| (ai, a.x))
        .collect();
    if let Some(t) = &spec.tracks {
        for w in 0..n_axles.saturating_sub(1) {
            for k in 1..=t.belt_points_between_wheels {
                let f = k as f64 / (t.belt_points_between_wheels + 1) as f64;
                let x = spec.axles[w].x + (spec.axles[w + 1].x - spec.axles[w].x) * f;
                positions.push((w, x));
            }
        }
    }
    let contact_count = positions.len() * n_wheels_axle;
    for (ai, px) in &positions {
        let a = &spec.axles[*ai];
        for side in [1.0, -1.0] {
            let per_wheel_load = loads[*ai] / 2.0 * (n_axles * 2) as f64 / contact_count as f64;
            let group = match (skid, a.driven, spec.powertrain.differential) {
                (true, _, _) => usize::from(side < 0.0),
                (false, true, Differential::Locked) => 0,
                _ => usize::MAX,
            };
            let steer_factor = if a.steered && x_front != x_rear_ref {
                (a.x - x_rear_ref) / (x_front - x_rear_ref)
            } else {
                0.0
            };
            wheels.push(WheelParams {
                hard: Vector3::new(*px, side * a.track / 2.0, -spec.chassis.com_height),
                side,
                steer_factor,
                steered: a.steered && !skid,
                driven: a.driven || spec.tracks.is_some(),
                group,
                spring: a.spring,
                damper: a.damper,
                travel: a.travel,
                static_compression: (per_wheel_load - unsprung * G).max(0.0) / a.spring,
            });
        }
    }
    // Groups: locked drivelines share one spin group; others each wheel its own.
    let mut next = if skid { 2 } else { 1 };
    for w in wheels.iter_mut() {
        if w.group == usize::MAX {
            w.group = next;
            next += 1;
        }
    }
    let groups = next;
    (wheels, groups)
}

/// The chassis box's contact points: a 5 x 3 grid on its bottom and top faces, and the sides' mid-height points.
fn body_points(spec: &VehicleSpec) -> Vec<Vector3<f64>> {
    let [l, w, h] = spec.chassis.size;
    let bottom = -spec.chassis.com_height - spec.wheels.radius + spec.chassis.ground_clearance;
    let mut body_points = Vec::new();
    for xi in 0..5 {
        for yi in 0..3 {
            let px = -l / 2.0 + l * xi as f64 / 4.0;
            let py = -w / 2.0 + w * yi as f64 / 2.0;
            body_points.push(Vector3::new(px, py, bottom));
            body_points.push(Vector3::new(px, py, bottom + h));
            if yi != 1 {
                body_points.push(Vector3::new(px, py, bottom + h / 2.0));
            }
        }
    }
    body_points
}

/// The highest height sample influencing each 4 x 4-sample block of the bilinear surface, and the blocks per row.
fn block_max(hm: &Heightmap) -> (Vec<f64>, usize) {
    let blocks_x = hm.nx.div_ceil(4);
    let blocks_y = hm.ny.div_ceil(4);
    let mut block_max = vec![f64::NEG_INFINITY; blocks_x * blocks_y];
    for iy in 0..hm.ny {
        for ix in 0..hm.nx {
            // Each sample influences the bilinear surface of the cells around it: widen by one block.
            for by in (iy / 4).saturating_sub(1)..=(iy / 4 + 1).min(blocks_y - 1) {
                for bx in (ix / 4).saturating_sub(1)..=(ix / 4 + 1).min(blocks_x - 1) {
                    let m = &mut block_max[by * blocks_x + bx];
                    *m = m.max(hm.at(ix, iy));
                }
            }
        }
    }
    (block_max, blocks_x)
}
