//! The vehicle-terrain model: a 6-DoF chassis, one vertical (suspension) DOF and one spin DOF per wheel,
//! multi-point wheel contact on the heightfield, tyre friction, soil, chassis contact, obstacles, powertrain,
//! steering and brakes. Integrated with semi-implicit Euler at a fixed step; wheel spin is integrated implicitly in
//! the tyre forces (so stiff friction is stable).
//!
//! Frames: the chassis frame is centred at the centre of mass, x forward, y left, z up. Wheel `k` hangs from a
//! hard point at `(x_axle, +-track/2, -com_height)` (the wheel centre at static ride height); its compression `x`
//! along the chassis up axis is measured from full droop, so the spring force is `spring * x` and the static sag is
//! `load / spring` (tested).
//!
//! Contacts, all penalty-based with damping:
//! - wheel-ground: 7 rim points (-60 .. 60 degrees) x 3 lateral offsets sample the bilinear heightfield; the
//!   deepest point gives the tyre deflection and a radial normal, so a wheel climbs a step and rolls over a ridge;
//! - tyre friction on rigid ground: `mu = min(tyre mu, patch mu)`; the rigid tyre is Coulomb friction regularised by
//!   a stiff bristle (it holds on slopes below `atan(mu)` with brakes), the handling tyre a Magic-Formula curve of
//!   the combined slip with a friction circle;
//! - soil: on deformable patches the wheel's force comes from [`crate::soil::SoilGrid`] instead;
//! - chassis-ground: points on the body box (bottom, edges, top) against the heightfield (high-centering,
//!   bottoming out, rollover);
//! - obstacles: body points and wheel spheres against rocks and trees ([`crate::collide`]).

use crate::collide::ObstacleSet;
use crate::planner::{Action, VehicleState};
use crate::soil::{SoilGrid, WheelGeometry};
use crate::vehicle::spec::{Differential, SteeringKind, TyreModel, VehicleSpec};
use crate::world::{Surface, World};
use nalgebra::{Matrix3, UnitQuaternion, Vector3};

const G: f64 = 9.81;
/// Rim sample angles (rad) and lateral offsets (fraction of the half width) of the wheel contact.
const RIM_ANGLES: [f64; 7] = [
    -1.047_197_551_196_597_6,
    -0.698_131_700_797_731_8,
    -0.349_065_850_398_865_9,
    0.0,
    0.349_065_850_398_865_9,
    0.698_131_700_797_731_8,
    1.047_197_551_196_597_6,
];
/// `(sin, cos)` of [`RIM_ANGLES`] (-60 .. 60 degrees in steps of 20), precomputed: no trigonometry in the step loop.
const RIM_SIN_COS: [(f64, f64); 7] = [
    (-0.866_025_403_784_438_6, 0.5),
    (-0.642_787_609_686_539_4, 0.766_044_443_118_978),
    (-0.342_020_143_325_668_7, 0.939_692_620_785_908_4),
    (0.0, 1.0),
    (0.342_020_143_325_668_7, 0.939_692_620_785_908_4),
    (0.642_787_609_686_539_4, 0.766_044_443_118_978),
    (0.866_025_403_784_438_6, 0.5),
];
/// Static tyre deflection of the rigid-ground tyre at full scale, m (sets the tyre's vertical stiffness).
const TYRE_STATIC_DEFLECTION: f64 = 0.01;
/// Rise of the ground per metre rolled for a wheel climbing out of a soil rut onto a rigid patch.
const RUT_EXIT_SLOPE: f64 = 0.5;
const RIM_LATERAL: [f64; 3] = [-0.66, 0.0, 0.66];
/// Fraction of the total mass carried by each wheel as unsprung mass.
const UNSPRUNG_FRACTION: f64 = 0.04;

#[derive(Clone, Debug)]
struct Wheel {
    /// Hard point (wheel centre at static ride height) in the chassis frame.
    hard: Vector3<f64>,
    /// +1 left, -1 right.
    side: f64,
    steer_factor: f64,
    steered: bool,
    /// Whether the powertrain drives this contact (all contacts of a tracked vehicle are driven).
    driven: bool,
    group: usize,
    spring: f64,
    damper: f64,
    travel: f64,
    /// Compression at static ride height (spring preload reference), m.
    static_compression: f64,
    compression: f64,
    compression_rate: f64,
    spin: f64,
    bristle: [f64; 2],
    steer_angle: f64,
    /// Tyre deflection of the previous step (for damping).
    deflection: f64,
    /// The wheel's last contact was soil: at its next rigid contact it may sit in a rut below the rigid surface.
    from_soil: bool,
    /// How far below the rigid surface the ground under this wheel still is while it climbs out of a soil rut onto
    /// a rigid patch (m; see `wheel_contact`). Zero otherwise.
    rut_offset: f64,
}

/// Tyre friction at one contact: the force `[fx, fy]` in the contact frame, `d fx / d(rim speed)` for the implicit
/// spin update, and the tyre's bristle deflection after this step (unchanged for the handling tyre).
#[derive(Clone, Copy, Debug)]
struct TyreForce {
    force: [f64; 2],
    stiffness: f64,
    bristle: [f64; 2],
}

/// What one step produced (for metrics).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepInfo {
    /// Mechanical power delivered by the powertrain to the wheels, W (positive when driving).
    pub drive_power: f64,
    /// Whether any part of the vehicle touches an obstacle.
    pub obstacle_contact: bool,
}

/// Why [`Simulation::copy_state_from`] refused a source.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StateCopyError {
    #[error("cannot copy the state of a {src} into a {dst}: different vehicles")]
    Vehicle { src: String, dst: String },
    #[error("cannot copy the state of a simulation of a different world (heightmap, soil grid or obstacles)")]
    World,
}

/// A vehicle driving in a world.
#[derive(Clone, Debug)]
pub struct Simulation {
    spec: VehicleSpec,
    world_patches: World,
    soil: SoilGrid,
    obstacles: ObstacleSet,
    dt: f64,
    mass: f64,
    inertia: Matrix3<f64>,
    inertia_inv: Matrix3<f64>,
    unsprung: f64,
    radius: f64,
    width: f64,
    wheel_inertia: f64,
    tyre_mu: f64,
    bristle_k: f64,
    bristle_c: f64,
    tyre_k: f64,
    tyre_c: f64,
    body_points: Vec<Vector3<f64>>,
    body_k: f64,
    body_c: f64,
    obstacle_k: f64,
    wheels: Vec<Wheel>,
    groups: usize,
    /// Highest terrain (plus one cell of slack) over 4 x 4-sample blocks: a body point above it cannot touch.
    block_max: Vec<f64>,
    blocks_x: usize,
    // state
    time: f64,
    pos: Vector3<f64>,
    rot: UnitQuaternion<f64>,
    vel: Vector3<f64>,
    /// Angular velocity in the chassis frame.
    omega: Vector3<f64>,
    gear: usize,
    steering: f64,
    accel_prev: Vector3<f64>,
    steps: u64,
    // scratch (preallocated; no allocation in the step loop)
    group_torque: Vec<f64>,
    group_num: Vec<f64>,
    group_den: Vec<f64>,
    group_spin: Vec<f64>,
    group_brake: Vec<f64>,
    /// Total spin inertia of each group (constant).
    group_inertia: Vec<f64>,
    contacts: Vec<WheelContact>,
}

#[derive(Clone, Copy, Debug, Default)]
struct WheelContact {
    active: bool,
    soil: bool,
    point: Vector3<f64>,
    normal: Vector3<f64>,
    /// Normal force magnitude (tyre deflection force), N.
    load: f64,
    mu: f64,
    tx: Vector3<f64>,
    ty: Vector3<f64>,
    /// Force on the wheel from the ground (soil: complete), world.
    soil_force: Vector3<f64>,
    soil_stiffness: f64,
    r_eff: f64,
}

/// Fixed physics step for a vehicle scale: 4 ms at full scale (Chrono: 5 ms), scaled by sqrt(scale) (Froude similitude keeps the
/// ratio of step to natural periods); chosen by the stability tests in `tests/physics_*.rs`.
pub fn default_dt(scale: f64) -> f64 {
    0.004 * scale.sqrt()
}

impl Simulation {
    /// Places the vehicle in `world` at `(x, y)` with heading `yaw`, resting on the ground.
    pub fn new(world: &World, spec: &VehicleSpec, x: f64, y: f64, yaw: f64) -> Simulation {
        let scale = spec.scale;
        let dt = default_dt(scale);
        let n_wheels_axle = 2;
        let mut wheels = Vec::new();
        let total = spec.chassis.mass;
        let unsprung = UNSPRUNG_FRACTION * total;
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
                wheels.push(Wheel {
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
                    compression: 0.0,
                    compression_rate: 0.0,
                    spin: 0.0,
                    bristle: [0.0; 2],
                    steer_angle: 0.0,
                    deflection: 0.0,
                    from_soil: false,
                    rut_offset: 0.0,
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
        let n = wheels.len() as f64;
        let sprung = total - n * unsprung;
        let i = spec.chassis.inertia;
        let inertia = Matrix3::from_diagonal(&Vector3::new(i[0], i[1], i[2]));
        let static_load = total * G / n;
        let tyre_k = static_load / (TYRE_STATIC_DEFLECTION * scale);
        let bristle_k = static_load / (0.005 * scale);
        let body_k = total * G / (0.02 * scale) / 4.0;
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
        let hm = &world.heightmap;
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
        let mut sim = Simulation {
            block_max,
            blocks_x,
            world_patches: world.clone(),
            soil: SoilGrid::new(world),
            obstacles: ObstacleSet::new(&world.obstacles),
            spec: spec.clone(),
            dt,
            mass: sprung,
            inertia,
            inertia_inv: inertia.try_inverse().unwrap_or_else(Matrix3::identity),
            unsprung,
            radius: spec.wheels.radius,
            width: spec.wheels.width,
            wheel_inertia: spec.wheels.inertia,
            tyre_mu: spec.wheels.mu,
            bristle_k,
            bristle_c: 2.0 * 0.7 * (bristle_k * total / n).sqrt(),
            tyre_k,
            tyre_c: 2.0 * 0.5 * (tyre_k * unsprung).sqrt(),
            body_points,
            body_k,
            body_c: 2.0 * 0.7 * (body_k * total / 4.0).sqrt(),
            obstacle_k: total * G / (0.002 * scale),
            groups,
            group_torque: vec![0.0; groups],
            group_num: vec![0.0; groups],
            group_den: vec![0.0; groups],
            group_spin: vec![0.0; groups],
            group_brake: vec![0.0; groups],
            group_inertia: (0..groups)
                .map(|g| {
                    spec.wheels.inertia
                        * wheels.iter().filter(|w| w.group == g).count().max(1) as f64
                })
                .collect(),
            contacts: vec![WheelContact::default(); wheels.len()],
            wheels,
            time: 0.0,
            pos: Vector3::zeros(),
            rot: UnitQuaternion::identity(),
            vel: Vector3::zeros(),
            omega: Vector3::zeros(),
            gear: 0,
            steering: 0.0,
            accel_prev: Vector3::zeros(),
            steps: 0,
        };
        sim.place(x, y, yaw);
        sim
    }

    /// Puts the vehicle at rest at `(x, y)` with heading `yaw`, pitched and rolled to the local terrain, its
    /// wheels at static compression.
    pub fn place(&mut self, x: f64, y: f64, yaw: f64) {
        let h = &self.world_patches.heightmap;
        let (l, w) = (self.spec.wheelbase().max(1e-3), self.spec.track().max(1e-3));
        let (c, s) = (yaw.cos(), yaw.sin());
        let hf = h.height_bilinear(x + c * l / 2.0, y + s * l / 2.0);
        let hb = h.height_bilinear(x - c * l / 2.0, y - s * l / 2.0);
        let hl = h.height_bilinear(x - s * w / 2.0, y + c * w / 2.0);
        let hr = h.height_bilinear(x + s * w / 2.0, y - c * w / 2.0);
        let pitch = -((hf - hb) / l).atan();
        let roll = ((hl - hr) / w).atan();
        self.rot = UnitQuaternion::from_euler_angles(roll, pitch, yaw);
        let ground = h.height_bilinear(x, y).max((hf + hb + hl + hr) / 4.0);
        // Along the body's up axis, so the wheels just touch a sloped plane instead of starting inside it.
        let lift = self.radius + self.spec.chassis.com_height + 0.01 * self.spec.scale;
        self.pos = Vector3::new(x, y, ground) + (self.rot * Vector3::z()) * lift;
        // On rough ground no wheel may start inside the terrain: raise the vehicle until every rim sample clears
        // it (it then drops a little and settles, as the release's spawn 1 m above the ground).
        let mut raise: f64 = 0.0;
        let (up, fwd) = (self.rot * Vector3::z(), self.rot * Vector3::x());
        for wh in &self.wheels {
            let centre = self.pos + self.rot * wh.hard;
            for &(sin, cos) in &RIM_SIN_COS {
                let p = centre + (fwd * sin - up * cos) * self.radius;
                raise = raise.max(h.height_bilinear(p.x, p.y) - p.z);
            }
        }
        self.pos.z += raise;
        self.vel = Vector3::zeros();
        self.omega = Vector3::zeros();
        for wh in &mut self.wheels {
            wh.compression = wh.static_compression.min(wh.travel);
            wh.compression_rate = 0.0;
            wh.spin = 0.0;
            wh.bristle = [0.0; 2];
            wh.deflection = 0.0;
            wh.from_soil = false;
            wh.rut_offset = 0.0;
        }
        self.gear = 0;
        self.steering = 0.0;
        self.time = 0.0;
        self.steps = 0;
        self.accel_prev = Vector3::zeros();
        self.soil.reset();
        self.obstacles.refresh_near(x, y, self.reach());
    }

    fn reach(&self) -> f64 {
        0.5 * self.spec.chassis.size[0].hypot(self.spec.chassis.size[1])
            + self.radius
            + 15.0 * self.spec.scale
    }

    /// Physics time step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    pub fn spec(&self) -> &VehicleSpec {
        &self.spec
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn position(&self) -> Vector3<f64> {
        self.pos
    }

    pub fn velocity(&self) -> Vector3<f64> {
        self.vel
    }

    pub fn orientation(&self) -> UnitQuaternion<f64> {
        self.rot
    }

    /// Spin rate of every wheel contact, rad/s.
    pub fn wheel_spins(&self) -> impl Iterator<Item = f64> + '_ {
        self.wheels.iter().map(|w| w.spin)
    }

    /// Suspension compression of every wheel from full droop, m.
    pub fn compressions(&self) -> impl Iterator<Item = f64> + '_ {
        self.wheels.iter().map(|w| w.compression)
    }

    /// Total kinetic energy (chassis translation and rotation, wheel spin), J.
    pub fn kinetic_energy(&self) -> f64 {
        let n = self.wheels.len() as f64;
        0.5 * (self.mass + n * self.unsprung) * self.vel.norm_squared()
            + 0.5 * self.omega.dot(&(self.inertia * self.omega))
            + self
                .wheels
                .iter()
                .map(|w| 0.5 * self.wheel_inertia * w.spin * w.spin)
                .sum::<f64>()
    }

    /// The soil grid (ruts).
    pub fn soil(&self) -> &SoilGrid {
        &self.soil
    }

    /// Physics steps taken.
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Sets position and velocity directly (tests: launch the vehicle).
    pub fn set_velocity(&mut self, v: Vector3<f64>) {
        self.vel = v;
        for w in &mut self.wheels {
            let fwd = self.rot * Vector3::x();
            w.spin = v.dot(&fwd) / self.radius;
        }
    }

    /// Makes this simulation's dynamic state a copy of `src`'s: chassis pose and velocities, time and step count,
    /// gear and steering, every wheel's suspension, spin, tyre bristle and deflection, the obstacle near list, and
    /// the soil memory (ruts, yield pressure, shear) within the square of half side `soil_radius` around the
    /// vehicle (`f64::INFINITY`: all of it). `src` must simulate the same vehicle in a world of the same geometry
    /// (checked: spec name, wheel count, heightmap and soil grid size, obstacle count).
    ///
    /// This is how a planner that uses the simulator as its model (MPPI-6) starts each rollout from the current
    /// state without building a simulation: it allocates nothing (the soil pool was sized by [`Simulation::new`]),
    /// and with an unlimited soil radius the copy then steps bit-identically to `src` (tested).
    pub fn copy_state_from(
        &mut self,
        src: &Simulation,
        soil_radius: f64,
    ) -> Result<(), StateCopyError> {
        if self.spec.name != src.spec.name || self.wheels.len() != src.wheels.len() {
            return Err(StateCopyError::Vehicle {
                src: src.spec.name.clone(),
                dst: self.spec.name.clone(),
            });
        }
        let (a, b) = (&self.world_patches.heightmap, &src.world_patches.heightmap);
        if a.nx != b.nx
            || a.ny != b.ny
            || a.cell != b.cell
            || self.obstacles.obstacles().len() != src.obstacles.obstacles().len()
            || !self.soil.same_grid(&src.soil)
        {
            return Err(StateCopyError::World);
        }
        self.time = src.time;
        self.pos = src.pos;
        self.rot = src.rot;
        self.vel = src.vel;
        self.omega = src.omega;
        self.gear = src.gear;
        self.steering = src.steering;
        self.accel_prev = src.accel_prev;
        self.steps = src.steps;
        for (w, s) in self.wheels.iter_mut().zip(&src.wheels) {
            w.compression = s.compression;
            w.compression_rate = s.compression_rate;
            w.spin = s.spin;
            w.bristle = s.bristle;
            w.steer_angle = s.steer_angle;
            w.deflection = s.deflection;
            w.from_soil = s.from_soil;
            w.rut_offset = s.rut_offset;
        }
        self.obstacles.copy_near_from(&src.obstacles);
        self.soil
            .copy_memory_from(&src.soil, src.pos.x, src.pos.y, soil_radius);
        Ok(())
    }

    /// Overwrites the chassis state with an observed ground-truth state (position, Cardan angles, world velocity,
    /// body angular velocity, applied steering, time), keeping the wheels' internal state and the soil memory: a
    /// model that tracks a vehicle it does not own (a planner's copy of the world) is corrected with it. The
    /// obstacle near list is refreshed at the new position.
    pub fn set_chassis_state(&mut self, s: &VehicleState) {
        self.pos = Vector3::new(s.position[0], s.position[1], s.position[2]);
        self.rot = UnitQuaternion::from_euler_angles(s.roll, s.pitch, s.yaw);
        self.vel = Vector3::new(s.velocity[0], s.velocity[1], s.velocity[2]);
        self.omega = Vector3::new(
            s.angular_velocity[0],
            s.angular_velocity[1],
            s.angular_velocity[2],
        );
        self.steering = s.steering;
        self.time = s.time;
        self.obstacles
            .refresh_near(self.pos.x, self.pos.y, self.reach());
    }

    /// Ground-truth state.
    pub fn state(&self) -> VehicleState {
        let (roll, pitch, yaw) = self.rot.euler_angles();
        let fwd = self.rot * Vector3::x();
        VehicleState {
            time: self.time,
            position: [self.pos.x, self.pos.y, self.pos.z],
            roll,
            pitch,
            yaw,
            velocity: [self.vel.x, self.vel.y, self.vel.z],
            angular_velocity: [self.omega.x, self.omega.y, self.omega.z],
            speed: self.vel.dot(&fwd),
            steering: self.steering,
        }
    }

    fn torque_curve(&self, rpm: f64) -> f64 {
        let c = &self.spec.powertrain.torque_curve;
        let rpm = rpm.max(0.0);
        for w in c.windows(2) {
            if rpm <= w[1][0] {
                let t = ((rpm - w[0][0]) / (w[1][0] - w[0][0])).clamp(0.0, 1.0);
                return w[0][1] + (w[1][1] - w[0][1]) * t;
            }
        }
        0.0
    }

    /// Advances the simulation by one fixed step with the given (validated) action.
    pub fn step(&mut self, action: &Action) -> StepInfo {
        let dt = self.dt;
        let mut info = StepInfo::default();
        self.steps += 1;
        self.soil.begin_step();
        if self.steps.is_multiple_of(20) {
            self.obstacles
                .refresh_near(self.pos.x, self.pos.y, self.reach());
        }
        // Steering with its rate limit.
        let max_delta = self.spec.steering.rate * dt;
        self.steering +=
            (action.steering.clamp(-1.0, 1.0) - self.steering).clamp(-max_delta, max_delta);
        let up = self.rot * Vector3::z();
        let fwd_body = self.rot * Vector3::x();
        let omega_w = self.rot * self.omega;
        let mut force = Vector3::new(0.0, 0.0, -self.mass * G);
        let mut torque_w = Vector3::zeros();
        // Ackermann angles.
        let wheelbase = self.spec.wheelbase().max(1e-6);
        let delta = self.steering * self.spec.steering.max_angle;
        let skid = self.spec.steering.kind == SteeringKind::Skid;
        for w in &mut self.wheels {
            w.steer_angle = if w.steered && delta.abs() > 1e-6 {
                let r = wheelbase / delta.tan();
                let li = w.steer_factor * wheelbase;
                (li / (r - w.side * w.hard.y.abs())).atan()
            } else {
                0.0
            };
        }
        // Powertrain: automatic gearbox on the mean driven-wheel speed.
        let pt = &self.spec.powertrain;
        let driven_spin =
            self.wheels.iter().map(|w| w.spin.abs()).sum::<f64>() / self.wheels.len().max(1) as f64;
        let reverse = action.throttle < 0.0;
        let ratio = if reverse {
            pt.reverse_gear.abs()
        } else {
            pt.gears[self.gear]
        } * pt.final_drive;
        let rpm = driven_spin / ratio * 60.0 / std::f64::consts::TAU;
        if !reverse {
            if rpm > pt.upshift_rpm && self.gear + 1 < pt.gears.len() {
                self.gear += 1;
            } else if rpm < pt.downshift_rpm && self.gear > 0 {
                self.gear -= 1;
            }
        }
        let motor_torque = self.torque_curve(rpm);
        let wheel_torque_total = motor_torque / ratio;
        // Distribute drive torque to spin groups.
        for g in 0..self.groups {
            self.group_torque[g] = 0.0;
            self.group_num[g] = 0.0;
            self.group_den[g] = 0.0;
            self.group_brake[g] = 0.0;
            self.group_spin[g] = 0.0;
        }
        let n_driven = self.wheels.iter().filter(|w| w.driven).count().max(1) as f64;
        if skid {
            let s = self.steering;
            let (ul, ur) = (
                (action.throttle - s).clamp(-1.0, 1.0),
                (action.throttle + s).clamp(-1.0, 1.0),
            );
            self.group_torque[0] = ul * wheel_torque_total / 2.0;
            self.group_torque[1] = ur * wheel_torque_total / 2.0;
        } else {
            for w in self.wheels.iter().filter(|w| w.driven) {
                self.group_torque[w.group] += action.throttle * wheel_torque_total / n_driven;
            }
        }
        // Contacts and tyre force trials.
        let mut power = 0.0;
        for k in 0..self.wheels.len() {
            let c = self.wheel_contact(k, &up, &fwd_body, &omega_w);
            self.contacts[k] = c;
            let w = &self.wheels[k];
            let g = w.group;
            self.group_den[g] += self.wheel_inertia;
            self.group_spin[g] += w.spin * self.wheel_inertia;
            self.group_brake[g] += self.spec.powertrain.brake_torque * action.brake.clamp(0.0, 1.0);
            if !c.active {
                continue;
            }
            let v_p = self.vel + omega_w.cross(&(c.point - self.pos));
            let (fx0, kx) = if c.soil {
                (c.soil_force.dot(&c.tx), c.soil_stiffness)
            } else {
                let vsx = v_p.dot(&c.tx) - w.spin * c.r_eff;
                let vsy = v_p.dot(&c.ty);
                let t = self.tyre_force(w, &c, vsx, vsy, dt);
                (t.force[0], t.stiffness)
            };
            self.group_num[g] -= fx0 * c.r_eff;
            self.group_den[g] += dt * kx * c.r_eff * c.r_eff;
        }
        // Implicit spin update per group, with Coulomb brakes.
        for g in 0..self.groups {
            let den = self.group_den[g];
            if den <= 0.0 {
                continue;
            }
            // The members of a group share one spin; this recovers it from the inertia-weighted sum.
            let spin = self.group_spin[g] / self.group_inertia[g];
            let free = spin + dt * (self.group_torque[g] + self.group_num[g]) / den;
            let brake_step = dt * self.group_brake[g] / den;
            let new = if free.abs() <= brake_step {
                0.0
            } else {
                free - free.signum() * brake_step
            };
            power += self.group_torque[g] * new;
            for w in self.wheels.iter_mut().filter(|w| w.group == g) {
                w.spin = new;
            }
        }
        info.drive_power = power;
        // Apply contact forces with the new spins.
        for k in 0..self.wheels.len() {
            let c = self.contacts[k];
            let hard_world = self.pos
                + self.rot
                    * (self.wheels[k].hard
                        - Vector3::new(
                            0.0,
                            0.0,
                            self.wheels[k].static_compression.min(self.wheels[k].travel),
                        )
                        + Vector3::new(0.0, 0.0, self.wheels[k].compression));
            let mut ground = Vector3::zeros();
            if c.active {
                if c.soil {
                    ground = c.soil_force;
                } else {
                    let w = &self.wheels[k];
                    let v_p = self.vel + omega_w.cross(&(c.point - self.pos));
                    let vsx = v_p.dot(&c.tx) - w.spin * c.r_eff;
                    let vsy = v_p.dot(&c.ty);
                    let t = self.tyre_force(w, &c, vsx, vsy, dt);
                    self.wheels[k].bristle = t.bristle;
                    let f = t.force;
                    ground = c.normal * c.load + c.tx * f[0] + c.ty * f[1];
                }
            }
            // Wheel vertical DOF along the chassis up axis.
            let a_rel = self.accel_prev;
            let wm = &mut self.wheels[k];
            let f_spring = wm.spring * wm.compression + wm.damper * wm.compression_rate;
            let bump = if wm.compression > wm.travel {
                20.0 * wm.spring * (wm.compression - wm.travel)
                    + wm.damper * wm.compression_rate.max(0.0)
            } else {
                0.0
            };
            let f_strut = (f_spring + bump).max(0.0);
            let gvec = Vector3::new(0.0, 0.0, -G) * self.unsprung;
            let along = (ground + gvec - self.unsprung * a_rel).dot(&up);
            let acc = (along - f_strut) / self.unsprung;
            wm.compression_rate += acc * dt;
            wm.compression += wm.compression_rate * dt;
            if wm.compression < 0.0 {
                wm.compression = 0.0;
                wm.compression_rate = wm.compression_rate.max(0.0);
            }
            // Chassis: strut force at the hard point plus the ground force components across the strut.
            let across = ground + gvec - up * (ground + gvec).dot(&up);
            let f_chassis = up * f_strut + across;
            force += f_chassis;
            let arm = if c.active { c.point } else { hard_world };
            torque_w +=
                (arm - self.pos).cross(&across) + (hard_world - self.pos).cross(&(up * f_strut));
        }
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
            let v = self.vel + omega_w.cross(&(pw - self.pos));
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
                    -vt / vtn.max(0.05 * self.spec.scale.sqrt()) * ground_mu * fnrm
                } else {
                    Vector3::zeros()
                };
                let f = n * fnrm + ft;
                force += f;
                torque_w += (pw - self.pos).cross(&f);
            }
            if let Some(oc) = obstacles_close
                .then(|| self.obstacles.sphere_contact(&pw, 0.0))
                .flatten()
            {
                let vn = v.dot(&oc.normal);
                let fnrm = (self.obstacle_k * oc.depth
                    - 2.0 * 0.5 * (self.obstacle_k * self.mass).sqrt() * vn.min(0.0))
                .max(0.0);
                let vt = v - oc.normal * vn;
                let vtn = vt.norm();
                let ft = if vtn > 1e-9 {
                    -vt / vtn.max(0.05) * 0.5 * fnrm
                } else {
                    Vector3::zeros()
                };
                let f = oc.normal * fnrm + ft;
                force += f;
                torque_w += (pw - self.pos).cross(&f);
                info.obstacle_contact = true;
            }
        }
        for k in 0..self.wheels.len() {
            let w = &self.wheels[k];
            let centre = self.pos
                + self.rot
                    * (w.hard
                        + Vector3::new(
                            0.0,
                            0.0,
                            w.compression - w.static_compression.min(w.travel),
                        ));
            if let Some(oc) = obstacles_close
                .then(|| self.obstacles.sphere_contact(&centre, self.radius))
                .flatten()
            {
                let v = self.vel + omega_w.cross(&(centre - self.pos));
                let vn = v.dot(&oc.normal);
                let fnrm = (self.obstacle_k * oc.depth
                    - 2.0 * 0.5 * (self.obstacle_k * self.mass).sqrt() * vn.min(0.0))
                .max(0.0);
                let f = oc.normal * fnrm;
                force += f;
                torque_w += (centre - self.pos).cross(&f);
                info.obstacle_contact = true;
            }
        }
        // Integrate the chassis (semi-implicit Euler).
        let acc = force / self.mass;
        self.accel_prev = acc;
        self.vel += acc * dt;
        self.pos += self.vel * dt;
        let torque_b = self.rot.inverse() * torque_w;
        let gyro = self.omega.cross(&(self.inertia * self.omega));
        self.omega += self.inertia_inv * (torque_b - gyro) * dt;
        self.rot = UnitQuaternion::new_normalize(
            self.rot.into_inner()
                * nalgebra::Quaternion::new(
                    1.0,
                    0.5 * self.omega.x * dt,
                    0.5 * self.omega.y * dt,
                    0.5 * self.omega.z * dt,
                ),
        );
        self.time += dt;
        info
    }

    fn patch_mu(&self, x: f64, y: f64) -> f64 {
        match self.world_patches.patch_at(x, y).surface {
            Surface::Rigid { friction } => friction.min(self.tyre_mu),
            Surface::Deformable { soil } => soil.friction_angle_deg.to_radians().tan(),
        }
    }

    /// Tyre friction on rigid ground for slip velocities `(vsx, vsy)`: see [`TyreForce`].
    fn tyre_force(&self, w: &Wheel, c: &WheelContact, vsx: f64, vsy: f64, dt: f64) -> TyreForce {
        let lim = c.mu * c.load;
        match self.spec.wheels.tyre {
            TyreModel::Rigid => {
                let trial = [
                    -(self.bristle_k * (w.bristle[0] + vsx * dt)) - self.bristle_c * vsx,
                    -(self.bristle_k * (w.bristle[1] + vsy * dt)) - self.bristle_c * vsy,
                ];
                let norm = trial[0].hypot(trial[1]);
                if norm > lim && norm > 0.0 {
                    // Sliding: the force sits on the friction circle and the bristle relaxes to carry it.
                    let s = vsx.hypot(vsy).max(0.01);
                    let force = [trial[0] / norm * lim, trial[1] / norm * lim];
                    TyreForce {
                        force,
                        stiffness: lim / s,
                        bristle: [-force[0] / self.bristle_k, -force[1] / self.bristle_k],
                    }
                } else {
                    TyreForce {
                        force: trial,
                        stiffness: self.bristle_k * dt + self.bristle_c,
                        bristle: [w.bristle[0] + vsx * dt, w.bristle[1] + vsy * dt],
                    }
                }
            }
            TyreModel::Handling => {
                let v_ref = (w.spin * c.r_eff)
                    .abs()
                    .max((vsx + w.spin * c.r_eff).abs())
                    .max(0.5 * self.spec.scale.sqrt());
                let s = vsx.hypot(vsy) / v_ref;
                let (b, cc) = (10.0, 1.9);
                let mag = lim * (cc * (b * s).atan()).sin();
                let stiffness = lim * b * cc / v_ref;
                if s < 1e-9 {
                    return TyreForce {
                        force: [0.0, 0.0],
                        stiffness,
                        bristle: w.bristle,
                    };
                }
                let d = [-vsx / (s * v_ref), -vsy / (s * v_ref)];
                TyreForce {
                    force: [mag * d[0], mag * d[1]],
                    stiffness,
                    bristle: w.bristle,
                }
            }
        }
    }

    /// Finds the contact of wheel `k` with the ground (rigid or soil) and its tyre deflection force. `omega_w` is the
    /// chassis' angular velocity in the world frame, as `step` already has it.
    fn wheel_contact(
        &mut self,
        k: usize,
        up: &Vector3<f64>,
        fwd_body: &Vector3<f64>,
        omega_w: &Vector3<f64>,
    ) -> WheelContact {
        let w = &self.wheels[k];
        let centre = self.pos
            + self.rot
                * (w.hard
                    + Vector3::new(0.0, 0.0, w.compression - w.static_compression.min(w.travel)));
        // Rotate the body's forward axis about its up axis by the steering angle (Rodrigues; up is a unit vector
        // perpendicular to fwd).
        let heading = if w.steer_angle == 0.0 {
            *fwd_body
        } else {
            let (s, c) = w.steer_angle.sin_cos();
            fwd_body * c + up.cross(fwd_body) * s
        };
        let axle = up.cross(&heading).normalize();
        let h = &self.world_patches.heightmap;
        if let Some(_soil) = self.soil.soil_at(centre.x, centre.y) {
            let vel = self.vel + omega_w.cross(&(centre - self.pos));
            let spin_vec = axle * w.spin + omega_w;
            let sc = self.soil.wheel_contact(
                &WheelGeometry {
                    centre,
                    axle,
                    radius: self.radius,
                    width: self.width,
                    velocity: vel,
                    angular_velocity: spin_vec,
                },
                self.dt,
            );
            // Sunk in soil, the wheel sits below the nominal surface; if it rolls onto a rigid patch it must climb out.
            let wm = &mut self.wheels[k];
            wm.deflection = 0.0;
            wm.from_soil = true;
            wm.rut_offset = 0.0;
            if sc.nodes == 0 {
                return WheelContact::default();
            }
            let n = sc.normal_dir;
            let tx = (heading - n * heading.dot(&n)).normalize();
            let ty = n.cross(&tx);
            let point = centre - n * self.radius;
            return WheelContact {
                active: true,
                soil: true,
                point,
                normal: n,
                load: sc.normal,
                mu: 0.0,
                tx,
                ty,
                // The soil acts on the spin through the force's component along tx at the rim radius (the soil's
                // torque about the axle is approximated that way).
                soil_force: sc.force,
                soil_stiffness: sc.traction_stiffness,
                r_eff: self.radius,
            };
        }
        let mut best = (0.0, Vector3::zeros(), 0.0);
        for lat in RIM_LATERAL {
            for (k, &(sin, cos)) in RIM_SIN_COS.iter().enumerate() {
                let p = centre
                    + axle * (lat * 0.5 * self.width)
                    + (heading * sin - up * cos) * self.radius;
                let depth_v = h.height_bilinear(p.x, p.y) - p.z;
                let depth = depth_v * cos;
                if depth > best.0 {
                    best = (depth, p, RIM_ANGLES[k]);
                }
            }
        }
        let wm = &mut self.wheels[k];
        // A wheel sunk in soil sits below the nominal surface, so when its centre crosses onto a rigid patch the
        // rigid ground is suddenly up to its sinkage above the rim bottom (the heightmap has no step there; only the
        // soil sank). Taken at face value the stiff tyre (1 cm static deflection) would fire the wheel out of the
        // ground like a catapult. Instead the wheel climbs out of its rut: the ground under it starts at the wheel's
        // sinkage below the rigid surface and rises as the wheel rolls on, RUT_EXIT_SLOPE metres per metre, as if
        // the rut's end were a ramp of soil.
        if wm.from_soil {
            wm.from_soil = false;
            wm.rut_offset = (best.0 - TYRE_STATIC_DEFLECTION * self.spec.scale).max(0.0);
            wm.deflection = best.0 - wm.rut_offset;
        }
        if wm.rut_offset > 0.0 {
            let v = self.vel + omega_w.cross(&(centre - self.pos));
            wm.rut_offset = (wm.rut_offset - v.xy().norm() * self.dt * RUT_EXIT_SLOPE).max(0.0);
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
        let rate = (depth - wm.deflection) / self.dt;
        wm.deflection = depth;
        let load = (self.tyre_k * depth + self.tyre_c * rate).max(0.0);
        let tx = (heading - normal * heading.dot(&normal)).normalize();
        let ty = normal.cross(&tx);
        let mu = match self.world_patches.patch_at(point.x, point.y).surface {
            Surface::Rigid { friction } => friction.min(self.tyre_mu),
            Surface::Deformable { .. } => self.tyre_mu,
        };
        WheelContact {
            active: true,
            soil: false,
            point,
            normal,
            load,
            mu,
            tx,
            ty,
            soil_force: Vector3::zeros(),
            soil_stiffness: 0.0,
            r_eff: (self.radius - depth).max(0.5 * self.radius),
        }
    }
}
