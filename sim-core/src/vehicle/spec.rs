//! Vehicle specifications: the data files in `sim-core/vehicles/*.toml` (units SI: m, kg, s, N, rad unless a key
//! says otherwise). Parsing a string is not IO: the built-in catalogue is compiled in with `include_str!`.

use super::action::VehicleInfo;
use serde::Deserialize;

/// Errors of the vehicle catalogue.
#[derive(Debug, thiserror::Error)]
pub enum VehicleError {
    #[error("vehicle file `{file}`: {message}")]
    Parse { file: String, message: String },
    #[error("vehicle file `{file}`: field `{field}`: {message}")]
    Field {
        file: String,
        field: String,
        message: String,
    },
    #[error("unknown vehicle `{0}` (known: {1})")]
    Unknown(String, String),
}

/// Steering mechanism.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SteeringKind {
    /// Road wheels steered with Ackermann geometry (pitman arm, rack and pinion, bellcrank linkages).
    Ackermann,
    /// Differential (skid) steering: left and right sides driven at different torques.
    Skid,
}

/// Tyre model on rigid ground.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TyreModel {
    /// Rigid cylinder with Coulomb friction (as the original release), regularised by a stiff bristle.
    Rigid,
    /// Slip-based handling tyre: Magic-Formula curve on the combined slip with a friction circle.
    Handling,
}

/// Differentials.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Differential {
    /// All driven wheels (of a side, for skid-steered vehicles) turn at one speed.
    Locked,
    /// Drive torque is split equally; wheels turn freely.
    Open,
    /// Open differentials locked by friction clutches that pass at most [`Powertrain::locking_limits`]: what a
    /// "locked" differential is in Chrono's `ChShaftsDriveline4WD` (a `ChShaftsClutch` with a torque limit between
    /// the differential's outputs). Two driven axles, wheel steering.
    Clutched,
}

/// Torque limits of a [`Differential::Clutched`] driveline's locking clutches, N m at the wheels.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockingLimits {
    /// Between the two wheels of a driven axle (Chrono's axle clutch joins the axle shafts).
    pub axle: f64,
    /// Between the front and the rear driven axle, summed over each axle's wheels (Chrono's central clutch joins the
    /// front and rear driveshafts: its limit divided by the conical gear's ratio).
    pub central: f64,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Chassis {
    /// Total mass including wheels, kg.
    pub mass: f64,
    /// Principal moments of inertia about the centre of mass (roll, pitch, yaw), kg m^2.
    pub inertia: [f64; 3],
    /// Centre of mass above the wheel-centre plane, m.
    pub com_height: f64,
    /// Collision box of the body: length, width, height, m; its bottom is `ground_clearance` above the ground at
    /// static ride height.
    pub size: [f64; 3],
    pub ground_clearance: f64,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Axle {
    /// Longitudinal position of the axle relative to the centre of mass, m (+ forward).
    pub x: f64,
    /// Track width (wheel centre to wheel centre), m.
    pub track: f64,
    pub steered: bool,
    pub driven: bool,
    /// Suspension spring rate per wheel, N/m; damping per wheel, N s/m; travel (full droop to bump stop), m.
    pub spring: f64,
    pub damper: f64,
    pub travel: f64,
    /// Suspension type (documentation: double_wishbone, single_wishbone, multilink, leaf_spring, solid_axle, torsion_bar).
    pub suspension: String,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Wheels {
    pub radius: f64,
    pub width: f64,
    /// Spin inertia of one wheel, kg m^2.
    pub inertia: f64,
    pub tyre: TyreModel,
    /// Tyre friction coefficient (combined with the ground's as the minimum, as Chrono does).
    pub mu: f64,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Powertrain {
    /// `"engine"` (internal combustion) or `"motor"` (electric); documentation only, the curve says it all.
    pub kind: String,
    /// Full-load torque curve: (speed rpm, torque N m) points, linearly interpolated, zero beyond the last.
    pub torque_curve: Vec<[f64; 2]>,
    /// Zero-throttle (engine braking) torque curve, same form: the engine's torque at a closed throttle, which at
    /// throttle `u` is blended as Chrono's `ChEngineSimpleMap` does, `u full + (1 - u) zero`; it resists the
    /// motion. None: no engine braking (a motor that freewheels).
    #[serde(default)]
    pub zero_throttle_curve: Option<Vec<[f64; 2]>>,
    /// Largest engine speed, rpm: the maps are read at `min(speed, max_rpm)` (Chrono's `GetMaxEngineSpeed`
    /// clamp), so a map that ends in a negative torque governs the speed. None: no clamp.
    #[serde(default)]
    pub max_rpm: Option<f64>,
    /// Forward gear ratios (motor speed / output speed is 1 / ratio), lowest first; reverse ratio (negative).
    pub gears: Vec<f64>,
    pub reverse_gear: f64,
    /// Final drive ratio (output / wheel speed multiplier as Chrono's conical gear: wheel = output * final).
    pub final_drive: f64,
    /// Upshift and downshift motor speeds, rpm.
    pub upshift_rpm: f64,
    pub downshift_rpm: f64,
    pub differential: Differential,
    /// The locking clutches' limits of a [`Differential::Clutched`] driveline (required there, refused elsewhere).
    #[serde(default)]
    pub locking_limits: Option<LockingLimits>,
    /// Total brake torque capacity of one wheel, N m.
    pub brake_torque: f64,
}

impl Powertrain {
    /// The engine's full-load torque at `rpm`, N m: [`Powertrain::torque_curve`] read at the clamped speed.
    pub fn full_load(&self, rpm: f64) -> f64 {
        map_at(&self.torque_curve, self.clamped(rpm))
    }

    /// The engine's closed-throttle torque at `rpm` (negative: engine braking), N m; None without that map.
    pub fn closed_throttle(&self, rpm: f64) -> Option<f64> {
        let at = self.clamped(rpm);
        self.zero_throttle_curve.as_ref().map(|c| map_at(c, at))
    }

    fn clamped(&self, rpm: f64) -> f64 {
        self.max_rpm.map_or(rpm, |m| rpm.min(m))
    }
}

/// A torque map's value at `rpm` (linear between its points, zero beyond its last), N m.
fn map_at(c: &[[f64; 2]], rpm: f64) -> f64 {
    let rpm = rpm.max(0.0);
    for w in c.windows(2) {
        if rpm <= w[1][0] {
            let t = ((rpm - w[0][0]) / (w[1][0] - w[0][0])).clamp(0.0, 1.0);
            return w[0][1] + (w[1][1] - w[0][1]) * t;
        }
    }
    0.0
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Steering {
    pub kind: SteeringKind,
    /// Mechanism (documentation: pitman_arm, rack_pinion, bellcrank, differential).
    pub mechanism: String,
    /// Largest road-wheel angle of the equivalent bicycle, rad (0 for skid steering).
    pub max_angle: f64,
    /// Steering rate limit, full range per second (normalised units / s).
    pub rate: f64,
}

#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tracks {
    /// Road wheels per side (their x positions follow the axles list) and the number of extra belt contact
    /// points between neighbouring road wheels.
    pub belt_points_between_wheels: usize,
}

/// One vehicle of the catalogue.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VehicleSpec {
    pub name: String,
    pub description: String,
    /// Scale relative to the full-size original (1, 1/6, 1/10).
    pub scale: f64,
    /// Cruising speed used by the benchmark's baselines, m/s; top speed, m/s.
    pub nominal_speed: f64,
    pub max_speed: f64,
    pub chassis: Chassis,
    pub axles: Vec<Axle>,
    pub wheels: Wheels,
    pub powertrain: Powertrain,
    pub steering: Steering,
    #[serde(default)]
    pub tracks: Option<Tracks>,
}

impl VehicleSpec {
    /// Parses and validates a vehicle file; `file` names it in errors.
    pub fn parse_toml(text: &str, file: &str) -> Result<VehicleSpec, VehicleError> {
        let spec: VehicleSpec = toml::from_str(text).map_err(|e| VehicleError::Parse {
            file: file.into(),
            message: e.to_string(),
        })?;
        spec.validate(file)?;
        Ok(spec)
    }

    fn validate(&self, file: &str) -> Result<(), VehicleError> {
        let bad = |field: &str, message: &str| field_error(file, field, message);
        if !pos(self.scale) || !pos(self.nominal_speed) || !pos(self.max_speed) {
            return bad("scale/nominal_speed/max_speed", "must be positive");
        }
        if !pos(self.chassis.mass) || !self.chassis.inertia.iter().all(|v| pos(*v)) {
            return bad("chassis", "mass and inertia must be positive");
        }
        if self.axles.len() < 2 {
            return bad("axles", "a vehicle needs at least two axles");
        }
        for (i, a) in self.axles.iter().enumerate() {
            if !pos(a.track) || !pos(a.spring) || a.damper < 0.0 || !pos(a.travel) {
                return bad(
                    &format!("axles[{i}]"),
                    "track, spring and travel must be positive, damper >= 0",
                );
            }
        }
        if !self.axles.iter().any(|a| a.driven) {
            return bad("axles", "no driven axle");
        }
        if !pos(self.wheels.radius)
            || !pos(self.wheels.width)
            || !pos(self.wheels.inertia)
            || !pos(self.wheels.mu)
        {
            return bad("wheels", "radius, width, inertia and mu must be positive");
        }
        self.validate_powertrain(file)?;
        if self.steering.kind == SteeringKind::Ackermann
            && !(self.steering.max_angle > 0.0 && self.steering.max_angle < 1.2)
        {
            return bad(
                "steering.max_angle",
                "must be in (0, 1.2) rad for Ackermann steering",
            );
        }
        if !pos(self.steering.rate) {
            return bad("steering.rate", "must be positive");
        }
        Ok(())
    }

    /// The powertrain: its differential's locking limits, its torque curves, engine speed and gears.
    fn validate_powertrain(&self, file: &str) -> Result<(), VehicleError> {
        let bad = |field: &str, message: &str| field_error(file, field, message);
        let p = &self.powertrain;
        match (p.differential, p.locking_limits) {
            (Differential::Clutched, Some(l)) => {
                let driven = self.axles.iter().filter(|a| a.driven).count();
                if !pos(l.axle) || !pos(l.central) {
                    return bad(
                        "powertrain.locking_limits",
                        "axle and central must be positive",
                    );
                }
                if driven != 2 || self.steering.kind == SteeringKind::Skid || self.tracks.is_some()
                {
                    return bad(
                        "powertrain.differential",
                        "\"clutched\" needs exactly two driven axles and wheel steering",
                    );
                }
            }
            (Differential::Clutched, None) => {
                return bad(
                    "powertrain.locking_limits",
                    "required with differential = \"clutched\"",
                );
            }
            (_, Some(_)) => {
                return bad(
                    "powertrain.locking_limits",
                    "only with differential = \"clutched\"",
                );
            }
            _ => {}
        }
        let curves = [
            ("powertrain.torque_curve", Some(&p.torque_curve)),
            (
                "powertrain.zero_throttle_curve",
                p.zero_throttle_curve.as_ref(),
            ),
        ];
        for (field, curve) in curves {
            if let Some(c) = curve {
                if c.len() < 2
                    || c.iter().flatten().any(|v| !v.is_finite())
                    || c.windows(2).any(|w| w[1][0] <= w[0][0])
                {
                    return bad(
                        field,
                        "needs at least two finite points with increasing speed",
                    );
                }
            }
        }
        if p.max_rpm.is_some_and(|m| !pos(m)) {
            return bad("powertrain.max_rpm", "must be a positive engine speed");
        }
        if p.gears.is_empty()
            || p.gears.iter().any(|g| !pos(*g))
            || p.reverse_gear >= 0.0
            || !pos(p.final_drive)
        {
            return bad(
                "powertrain.gears",
                "forward gears and final drive must be positive, reverse negative",
            );
        }
        Ok(())
    }

    /// Distance between the first and last axle, m.
    pub fn wheelbase(&self) -> f64 {
        let xs = self.axles.iter().map(|a| a.x);
        xs.clone().fold(f64::NEG_INFINITY, f64::max) - xs.fold(f64::INFINITY, f64::min)
    }

    /// Largest track, m.
    pub fn track(&self) -> f64 {
        self.axles.iter().map(|a| a.track).fold(0.0, f64::max)
    }

    /// What planners may know about this vehicle.
    pub fn info(&self) -> VehicleInfo {
        VehicleInfo {
            name: self.name.clone(),
            scale: self.scale,
            wheelbase: self.wheelbase(),
            track: self.track(),
            length: self.chassis.size[0],
            width: self.chassis.size[1].max(self.track() + self.wheels.width),
            max_steer: if self.steering.kind == SteeringKind::Ackermann {
                self.steering.max_angle
            } else {
                0.0
            },
            skid_steer: self.steering.kind == SteeringKind::Skid,
            nominal_speed: self.nominal_speed,
            max_speed: self.max_speed,
        }
    }
}

/// The built-in catalogue, one file per vehicle.
const BUILTIN: &[(&str, &str)] = &[
    ("hmmwv.toml", include_str!("../../vehicles/hmmwv.toml")),
    (
        "hmmwv_sixth.toml",
        include_str!("../../vehicles/hmmwv_sixth.toml"),
    ),
    ("v4w.toml", include_str!("../../vehicles/v4w.toml")),
    ("artcar.toml", include_str!("../../vehicles/artcar.toml")),
    ("gator.toml", include_str!("../../vehicles/gator.toml")),
    ("feda.toml", include_str!("../../vehicles/feda.toml")),
    ("man7t.toml", include_str!("../../vehicles/man7t.toml")),
    ("man10t.toml", include_str!("../../vehicles/man10t.toml")),
    ("m113.toml", include_str!("../../vehicles/m113.toml")),
];

/// Every built-in vehicle, in catalogue order.
pub fn builtin_vehicles() -> Vec<VehicleSpec> {
    BUILTIN
        .iter()
        .map(|(f, t)| VehicleSpec::parse_toml(t, f).expect("built-in vehicle files are valid"))
        .collect()
}

/// A built-in vehicle by name.
pub fn vehicle_by_name(name: &str) -> Result<VehicleSpec, VehicleError> {
    let all = builtin_vehicles();
    let names = all
        .iter()
        .map(|v| v.name.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    all.iter()
        .find(|v| v.name == name)
        .cloned()
        .ok_or_else(|| VehicleError::Unknown(name.into(), names))
}

/// A vehicle file's field `field` is wrong: `message` says how.
fn field_error(file: &str, field: &str, message: &str) -> Result<(), VehicleError> {
    Err(VehicleError::Field {
        file: file.into(),
        field: field.into(),
        message: message.into(),
    })
}

/// A finite, positive number.
fn pos(v: f64) -> bool {
    v.is_finite() && v > 0.0
}
