//! A configuration checked and resolved: the vehicle, scale, control period, crops, planners and the number of
//! frames that ends the run; and the dataset's spec.

use super::source::{check_training_set, open};
use super::{GenerateConfig, GenerateError};
use crate::record::DatasetKind;
use crate::spec::{CropSpec, DatasetSpec, Variant};
use sim_core::runner::control_every;
use sim_core::vehicle::{default_dt, VehicleSpec};
use tasks::TaskSet;

/// The resolved settings every episode of a run shares.
#[derive(Clone, Debug)]
pub struct Plan {
    pub scale: f64,
    /// Simulated seconds a frame (the control period the physics step allows).
    pub period: f64,
    pub crop: CropSpec,
    /// The crop every frame records (full variant only).
    pub record_crop: Option<sim_core::observe::CropSpec>,
    /// Frames that end the run.
    pub target_frames: u64,
}

/// Checks the options that need no task set.
pub(crate) fn check(cfg: &GenerateConfig) -> Result<(), GenerateError> {
    let bad = GenerateError::param;
    if !(cfg.hours.is_finite() && cfg.hours > 0.0 && cfg.hours <= 1e6) {
        return Err(bad("hours", format!("{} must be in (0, 1e6]", cfg.hours)));
    }
    let rate = cfg.control_rate_hz;
    if !(rate.is_finite() && rate > 0.0 && rate <= 1000.0) {
        return Err(bad(
            "control_rate_hz",
            format!("{rate} Hz must be in (0, 1000]"),
        ));
    }
    if !(1..=512).contains(&cfg.crop_size) {
        return Err(bad(
            "crop_size",
            format!("{} must be in 1..=512", cfg.crop_size),
        ));
    }
    if let Some(r) = cfg.crop_resolution {
        if !(r.is_finite() && r > 0.0) {
            return Err(bad("crop_resolution", format!("{r} m must be positive")));
        }
    }
    if !(cfg.max_time.is_finite() && cfg.max_time > 0.0 && cfg.max_time <= 3600.0) {
        return Err(bad(
            "max_time",
            format!("{} s must be in (0, 3600]", cfg.max_time),
        ));
    }
    if cfg.kind != DatasetKind::Random && !cfg.speed_profile.is_constant() {
        return Err(bad(
            "speed_profile",
            format!(
                "{:?} applies to random exploration only (a {:?} run's speeds are its planners')",
                cfg.speed_profile, cfg.kind
            ),
        ));
    }
    let names = || cfg.planners.join(", ");
    match cfg.kind {
        DatasetKind::Random if !cfg.planners.is_empty() => {
            return Err(bad(
                "planners",
                format!("a random run drives no planner (got {})", names()),
            ));
        }
        DatasetKind::Expert if cfg.planners.len() != 1 => {
            return Err(bad(
                "planners",
                format!("an expert run drives with one planner (got `{}`)", names()),
            ));
        }
        DatasetKind::Failures if cfg.planners.is_empty() => {
            return Err(bad(
                "planners",
                "a failures run needs at least one planner".to_string(),
            ));
        }
        _ => {}
    }
    for p in &cfg.planners {
        let Some(planner) = baselines::by_name(p) else {
            return Err(bad(
                "planners",
                format!(
                    "unknown planner `{p}` (built-in: {})",
                    baselines::NAMES.join(", ")
                ),
            ));
        };
        // Expert and evaluation episodes run as `vb eval` runs them: at the planner's own rate.
        if (planner.control_rate_hz() - rate).abs() > 1e-9 {
            return Err(bad(
                "control_rate_hz",
                format!(
                    "{rate} Hz: planner `{p}` acts at {} Hz, and its episodes are recorded at the rate it acts",
                    planner.control_rate_hz()
                ),
            ));
        }
    }
    Ok(())
}

impl Plan {
    /// Checks `cfg` and resolves it for `vehicle` at `scale`.
    pub fn new(
        cfg: &GenerateConfig,
        vehicle: &VehicleSpec,
        scale: f64,
    ) -> Result<Plan, GenerateError> {
        check(cfg)?;
        let dt = default_dt(vehicle.scale);
        let period = control_every(cfg.control_rate_hz, dt) as f64 * dt;
        let crop = CropSpec {
            size: cfg.crop_size,
            resolution: cfg.crop_resolution.unwrap_or(scale),
        };
        let record_crop = (cfg.variant == Variant::Full).then_some(sim_core::observe::CropSpec {
            size: crop.size,
            resolution: crop.resolution,
        });
        Ok(Plan {
            scale,
            period,
            crop,
            record_crop,
            target_frames: (cfg.hours * 3600.0 / period).ceil() as u64,
        })
    }
}

/// The spec of a run's main dataset.
pub fn make_spec(
    cfg: &GenerateConfig,
    set: &TaskSet,
    vehicle: &VehicleSpec,
    plan: &Plan,
) -> DatasetSpec {
    DatasetSpec {
        kind: cfg.kind,
        variant: cfg.variant,
        vehicle: vehicle.name.as_str().into(),
        wheels: contact_count(vehicle),
        scale: plan.scale,
        control_rate_hz: 1.0 / plan.period,
        crop: plan.crop,
        sim_version: sim_core::SIM_VERSION.into(),
        task_set_version: set.version().to_string(),
        task_set_seed: set.manifest.seed,
        seed: cfg.seed,
        speed_profile: cfg.speed_profile,
        // Only a set the training check refuses makes an analysis-only dataset (the flag alone does not).
        analysis_only: check_training_set(set).is_err(),
    }
}

/// Wheel (track) contacts the simulator reports for `vehicle`: two per axle, plus two per belt point between
/// neighbouring road wheels of a tracked vehicle (`Simulation::wheels`; a test checks every built-in vehicle).
pub fn contact_count(vehicle: &VehicleSpec) -> usize {
    let axles = vehicle.axles.len();
    let belt = vehicle.tracks.as_ref().map_or(0, |t| {
        axles.saturating_sub(1) * t.belt_points_between_wheels
    });
    2 * (axles + belt)
}

/// The spec of `cfg`'s main dataset (its task set is opened and checked, no world is loaded).
pub fn spec(cfg: &GenerateConfig) -> Result<DatasetSpec, GenerateError> {
    let (set, vehicle, scale) = open(cfg)?;
    let plan = Plan::new(cfg, &vehicle, scale)?;
    Ok(make_spec(cfg, &set, &vehicle, &plan))
}

/// The spec of the failures dataset a random or expert run of `cfg` feeds (its main spec, of kind `failures`).
pub fn failures_spec(cfg: &GenerateConfig) -> Result<DatasetSpec, GenerateError> {
    Ok(DatasetSpec {
        kind: DatasetKind::Failures,
        ..spec(cfg)?
    })
}
