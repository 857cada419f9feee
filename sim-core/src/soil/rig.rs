//! A single-wheel test rig on the Soil Contact Model, as the soil-bin rigs of terramechanics (and Chrono's
//! single-wheel SCM demo): a rigid wheel of radius `r` and width `b` carrying a vertical load `W`, moving forward at
//! constant speed over fresh flat soil, either towed or driven at a fixed slip. It measures the steady sinkage, the
//! drawbar pull (longitudinal soil force; negative = motion resistance) and the vertical force.
//!
//! The wheel's only free motions are its vertical position and, when towed, its spin. The vertical DOF (mass `W / g`)
//! is integrated linearly implicitly with the soil's Jacobians ([`SoilContact::normal_stiffness`],
//! [`SoilContact::normal_damping`]):
//! `(m + dt C + dt^2 K) (v' - v) = dt (F_z - W - dt K v)`, `z' = z + dt v'`, so it is stable at the vehicle's 4 ms step
//! although the elastic soil under a wheel is far stiffer than explicit integration of a few hundred kilograms
//! allows. A towed wheel spins freely (no drive torque; inertia [`WheelRig::inertia`]), its spin integrated
//! implicitly with [`SoilContact::spin_stiffness`]; at steady state the soil's torque about the axle averages
//! to zero. A driven wheel spins at `omega = v / (r (1 - i))`.
//!
//! Everything is allocated in [`WheelRig::run`] before the first step (one soil grid); the step loop allocates
//! nothing.

use super::{SoilContact, SoilGrid, WheelGeometry};
use crate::world::{Heightmap, Semantic, SoilParams, Surface, World};
use nalgebra::Vector3;

/// Gravity used to turn the load into the wheel's mass, m/s^2.
const G: f64 = 9.81;

/// How the wheel's spin is set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Drive {
    /// No drive torque: the spin follows from the soil's torque about the axle.
    Towed,
    /// Driven at slip `i = 1 - v / (omega r)` (0 rolling, 1 spinning in place).
    Slip(f64),
}

/// Means over the last [`WheelRig::window`] metres of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RigResult {
    /// Depth of the wheel's lowest point below the undeformed surface, m.
    pub sinkage: f64,
    /// Longitudinal soil force along the direction of travel, N (negative: motion resistance).
    pub drawbar_pull: f64,
    /// Vertical soil force, N (equals the load at steady state).
    pub vertical_force: f64,
    /// Soil torque about the axle, N m (positive: against the rolling spin; near zero when towed).
    pub torque: f64,
    /// Slip `1 - v / (omega r)` with the mean spin (set when driven; when towed the free-rolling slip, which is
    /// poorly determined: the soil's torque about the axle changes little with the spin while the elastic shear
    /// of the arc takes up the difference, so the towed spin wanders).
    pub slip: f64,
}

/// The rig's settings. [`WheelRig::new`] gives the defaults.
#[derive(Clone, Copy, Debug)]
pub struct WheelRig {
    pub soil: SoilParams,
    /// Wheel radius and width, m.
    pub radius: f64,
    pub width: f64,
    /// Vertical load, N.
    pub load: f64,
    /// Forward speed, m/s (default 0.25: slow enough that the soil's damping `R` adds little to the quasi-static
    /// pressure, as in the theory the rig is compared with).
    pub speed: f64,
    /// Time step, s (default 4 ms, the vehicle's).
    pub dt: f64,
    /// Node spacing, m (default 0.1, the benchmark's).
    pub spacing: f64,
    /// Distance travelled, m (default 3).
    pub distance: f64,
    /// The means are taken over the last `window` metres, m (default 1).
    pub window: f64,
    /// Spin inertia of a towed wheel, kg m^2 (default 10, about a HMMWV wheel with its tyre).
    pub inertia: f64,
    /// Lateral position of the wheel's centre, m (default 0.037: on no node line nor half-way between).
    pub lateral: f64,
    /// Wheels running one behind the other in the same track (default 1): each pass runs over the ruts the
    /// previous ones left (multi-pass, as a vehicle's rear wheels follow its front wheels); the results are the
    /// means over all passes, i.e. per wheel of such a vehicle.
    pub passes: usize,
}

impl WheelRig {
    pub fn new(soil: SoilParams, radius: f64, width: f64, load: f64) -> WheelRig {
        WheelRig {
            soil,
            radius,
            width,
            load,
            speed: 0.25,
            dt: 4e-3,
            spacing: 0.1,
            distance: 3.0,
            window: 1.0,
            inertia: 10.0,
            lateral: 0.037,
            passes: 1,
        }
    }

    /// Flat, fresh soil of the rig's parameters at its node spacing (allocates).
    fn fresh_soil(&self) -> SoilGrid {
        let world = World::uniform(
            Heightmap::from_fn(1.0, |_, _| 0.0),
            Semantic::Mud,
            Surface::Deformable { soil: self.soil },
        );
        SoilGrid::with_spacing(world, self.spacing)
    }

    /// Runs the rig on fresh soil, [`WheelRig::passes`] times over the same track.
    pub fn run(&self, drive: Drive) -> RigResult {
        let mut grid = self.fresh_soil();
        let (r, v, dt) = (self.radius, self.speed, self.dt);
        let mass = self.load / G;
        let (mut z, mut vz, mut omega) = (r, 0.0, 0.0);
        let (x0, y) = (-1.0, self.lateral);
        let steps = (self.distance / (v * dt)).round() as usize;
        let from = steps.saturating_sub((self.window / (v * dt)).round() as usize);
        let mut sum = RigResult::default();
        for k in (0..self.passes.max(1)).flat_map(|_| 0..steps) {
            if k == 0 {
                // Each pass starts touching the (possibly rutted) surface at rest vertically.
                let start = grid.surface_height(x0, y) + r;
                (z, vz) = (start, 0.0);
                omega = match drive {
                    Drive::Towed => v / r,
                    Drive::Slip(i) => v / (r * (1.0 - i)),
                };
            }
            grid.begin_step();
            let w = WheelGeometry {
                centre: Vector3::new(x0 + v * dt * k as f64, y, z),
                axle: Vector3::y(),
                radius: r,
                width: self.width,
                velocity: Vector3::new(v, 0.0, vz),
                angular_velocity: Vector3::new(0.0, omega, 0.0),
            };
            let c: SoilContact = grid.wheel_contact(&w, dt);
            vz += implicit_dv(&c, self.load, mass, vz, dt);
            z += dt * vz;
            if drive == Drive::Towed {
                omega += dt * c.torque.y / (self.inertia + dt * c.spin_stiffness);
            }
            if k >= from {
                sum.sinkage += r - z;
                sum.drawbar_pull += c.force.x;
                sum.vertical_force += c.force.z;
                sum.torque -= c.torque.y;
                sum.slip += omega;
            }
        }
        let n = ((steps - from) * self.passes.max(1)).max(1) as f64;
        RigResult {
            sinkage: sum.sinkage / n,
            drawbar_pull: sum.drawbar_pull / n,
            vertical_force: sum.vertical_force / n,
            torque: sum.torque / n,
            slip: 1.0 - v / (sum.slip / n * r),
        }
    }

    /// The wheel pressed statically into fresh soil (no travel, no spin): its load ramped on over
    /// [`STATIC_RAMP`] s, then held for as long again; returns the sinkage, m, averaged over the last
    /// second. `offset` places the wheel's centre along the track relative to the grid's nodes, m.
    pub fn static_sinkage(&self, offset: f64) -> f64 {
        let mut grid = self.fresh_soil();
        let (r, dt) = (self.radius, self.dt);
        let mass = self.load / G;
        let (mut z, mut vz) = (r, 0.0);
        let steps = (2.0 * STATIC_RAMP / dt).round() as usize;
        let from = steps - (1.0 / dt).round() as usize;
        let mut sum = 0.0;
        for k in 0..steps {
            let load = self.load * (k as f64 * dt / STATIC_RAMP).min(1.0);
            grid.begin_step();
            let w = WheelGeometry {
                centre: Vector3::new(offset, self.lateral, z),
                axle: Vector3::y(),
                radius: r,
                width: self.width,
                velocity: Vector3::new(0.0, 0.0, vz),
                angular_velocity: Vector3::zeros(),
            };
            let c = grid.wheel_contact(&w, dt);
            vz += implicit_dv(&c, load, mass, vz, dt);
            z += dt * vz;
            if k >= from {
                sum += r - z;
            }
        }
        sum / (steps - from) as f64
    }
}

/// The linearly implicit change of the wheel's vertical velocity over a step, with the soil's vertical stiffness
/// and damping: `(m + dt C + dt^2 K) dv = dt (F_z - W - dt K v)`.
fn implicit_dv(c: &SoilContact, load: f64, mass: f64, vz: f64, dt: f64) -> f64 {
    let kz = c.normal_stiffness;
    dt * (c.force.z - load - dt * kz * vz) / (mass + dt * c.normal_damping + dt * dt * kz)
}

/// Time over which [`WheelRig::static_sinkage`] ramps the load on, s.
pub const STATIC_RAMP: f64 = 2.0;

/// Load carried by a rigid wheel (radius `r`, width `b`) pressed statically to sinkage `z0` into Bekker soil: the
/// pressure-sinkage law `p = (k_c / b + k_phi) z^n` integrated over the whole contact chord (Bekker; Wong, Theory
/// of Ground Vehicles, the static rigid wheel), by the midpoint rule on 20 000 intervals.
pub fn bekker_static_load(soil: SoilParams, r: f64, b: f64, z0: f64) -> f64 {
    static_load(soil, r, b, b, z0)
}

/// [`bekker_static_load`] over a wheel of width `width` with the pressure-sinkage law's `b` given apart.
fn static_load(soil: SoilParams, r: f64, width: f64, b: f64, z0: f64) -> f64 {
    let k = soil.k_c / b + soil.k_phi;
    let half = (r * r - (r - z0).powi(2)).max(0.0).sqrt();
    let n = 20_000;
    (0..n)
        .map(|i| {
            let x = -half + (i as f64 + 0.5) * 2.0 * half / n as f64;
            let z = z0 - (r - (r * r - x * x).sqrt());
            width * k * z.max(0.0).powf(soil.n) * 2.0 * half / n as f64
        })
        .sum()
}

/// The static sinkage under which [`bekker_static_load`] carries `load`, m (bisection to 1e-12 m).
pub fn bekker_static_sinkage(soil: SoilParams, r: f64, b: f64, load: f64) -> f64 {
    static_sinkage(soil, r, b, b, load)
}

fn static_sinkage(soil: SoilParams, r: f64, width: f64, b: f64, load: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, r);
    while hi - lo > 1e-12 {
        let mid = 0.5 * (lo + hi);
        if static_load(soil, r, width, b, mid) < load {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

/// Bekker's `b` of a static wheel's contact patch as Chrono's SCM computes it (`2 A / P` of the hull of the nodes
/// whose rays hit the wheel, up to Chrono's 0.1 m test height above the surface, on a grid of spacing `delta`): the
/// chord where the rim is less than 0.1 m above the surface, shortened by `delta`, by the width shortened by `delta`
/// (a rectangle's `L W / (L + W)`); `f64::INFINITY` (no `k_c` term) when the hull has no area. Sinkage `z0`, m.
pub fn chrono_patch_b(r: f64, width: f64, z0: f64, delta: f64) -> f64 {
    let above = r - z0 - 0.1;
    let chord = if above <= 0.0 {
        2.0 * r
    } else {
        2.0 * (r * r - above * above).max(0.0).sqrt()
    };
    let (l, w) = (chord - delta, width - delta);
    if l <= 0.0 || w <= 0.0 {
        f64::INFINITY
    } else {
        l * w / (l + w)
    }
}

/// [`bekker_static_sinkage`] with Bekker's `b` of Chrono's contact patch ([`chrono_patch_b`] at the benchmark's
/// 0.1 m grid; a fixed point in the sinkage, three iterations from the wheel's width).
pub fn chrono_static_sinkage(soil: SoilParams, r: f64, width: f64, load: f64) -> f64 {
    let mut z = bekker_static_sinkage(soil, r, width, load);
    for _ in 0..3 {
        z = static_sinkage(soil, r, width, chrono_patch_b(r, width, z, 0.1), load);
    }
    z
}
