//! Perception profiles: every channel's parameters with their units, the built-in `ideal`, `nominal` and
//! `degraded`, a user's TOML file, and the profile's identity (a hash of its name and parameters, which results
//! carry like the vehicle and the rules).
//!
//! Every parameter defaults to perfect perception, so a file names only what it degrades. Lengths are at full
//! scale; a world of scale `s` multiplies them by `s` (a tenth-scale vehicle carries a tenth-scale sensor).

use serde::{Deserialize, Serialize};

/// Why a profile was refused.
#[derive(Debug, thiserror::Error)]
pub enum ProfileError {
    #[error("perception profile: {0}")]
    Toml(String),
    #[error("perception profile: {field} = {value} {rule}")]
    Range {
        field: &'static str,
        value: f64,
        rule: &'static str,
    },
    #[error("perception profile: the semantic confusion matrix must be 10 x 10 with rows of non-negative numbers summing to 1 ({0})")]
    Confusion(String),
    #[error(
        "unknown perception profile `{0}` (built-in: ideal, nominal, degraded; or a TOML file)"
    )]
    Unknown(String),
    #[error("perception profile {path}: {message}")]
    File { path: String, message: String },
}

/// State estimation: the planner's estimate of the vehicle's state.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct StateNoise {
    /// Drift of the estimated position as a share of the distance travelled (odometry's error, as KITTI's odometry
    /// benchmark reports it), in a direction drawn once per episode.
    pub drift_share: f64,
    /// Drift of the estimated heading, deg/s, its sign drawn once per episode; the estimated map frame turns about
    /// the start.
    pub yaw_drift_deg_per_s: f64,
    /// White position noise (GNSS-like), standard deviation per axis, m.
    pub position_sigma: f64,
    /// White velocity noise, m/s per axis, and a bias drawn once per episode per axis (standard deviation), m/s.
    pub velocity_sigma: f64,
    pub velocity_bias: f64,
    /// White angular-rate noise, deg/s per axis, and a bias drawn once per episode per axis, deg/s.
    pub rate_sigma_deg: f64,
    pub rate_bias_deg: f64,
    /// The planner sees the estimate of this many control steps ago.
    pub latency_steps: u32,
}

/// The elevation map: given whole (`online = false`, today's observations) or built online from a range sensor.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ElevationNoise {
    pub online: bool,
    /// Sensor range, m.
    pub range: f64,
    /// Horizontal field of view centred on the heading, degrees (360: a spinning lidar).
    pub fov_deg: f64,
    /// Sensor height above the chassis reference point, m.
    pub mount_height: f64,
    /// Scans per simulated second.
    pub update_hz: f64,
    /// A measured height's variance is `height_noise_k * d^2`, `d` the range to the cell (elevation_mapping_cupy's
    /// point variance, `sensor_noise_factor * z^2`); repeated views are fused (inverse-variance).
    pub height_noise_k: f64,
}

/// Semantics: the class the planner is told each patch has, and through it the friction or soil it is told.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SemanticsNoise {
    /// Probability that a patch's class is wrong, the wrong class drawn uniformly among the other nine.
    pub error_rate: f64,
    /// A full confusion matrix instead (`confusion[true][seen]`, classes in the release's order: clay, concrete,
    /// dirt, grass, gravel, rock, wood, mud, sand, snow); overrides `error_rate`.
    pub confusion: Option<Vec<Vec<f64>>>,
}

/// Obstacle detection.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObstacleNoise {
    /// Probability of detecting an obstacle at zero range, per scan.
    pub detection_max: f64,
    /// Range at which the probability halves, m (it falls as `exp(-ln 2 (r / r_half)^2)`); 0: no fall-off.
    pub detection_half_range: f64,
    /// Phantom obstacles per scan (Poisson mean), placed uniformly within the sensor's range; each lasts one scan.
    pub false_positives_per_update: f64,
}

impl Default for ObstacleNoise {
    fn default() -> ObstacleNoise {
        ObstacleNoise {
            detection_max: 1.0,
            detection_half_range: 0.0,
            false_positives_per_update: 0.0,
        }
    }
}

/// Actuation: what the vehicle does with the planner's command.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ActuationNoise {
    /// The vehicle applies the command of this many control steps ago.
    pub latency_steps: u32,
    /// Steering bias, road-wheel degrees, its sign drawn once per episode.
    pub steering_bias_deg: f64,
    /// Throttle gain drawn once per episode, uniform in `[1 - spread, 1 + spread]`.
    pub throttle_gain_spread: f64,
    /// First-order lag of steering and throttle, time constant in s.
    pub lag_s: f64,
}

/// A named perception profile.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Profile {
    /// `ideal`, `nominal`, `degraded`, or a user file's own name (its stem when it gives none).
    pub name: String,
    pub state: StateNoise,
    pub elevation: ElevationNoise,
    pub semantics: SemanticsNoise,
    pub obstacles: ObstacleNoise,
    pub actuation: ActuationNoise,
}

/// The built-in profiles' names.
pub const BUILTIN: [&str; 3] = ["ideal", "nominal", "degraded"];

impl Profile {
    /// Ground truth, today's observations: the default.
    pub fn ideal() -> Profile {
        Profile {
            name: "ideal".into(),
            ..Profile::default()
        }
    }

    /// A built-in profile by name.
    pub fn builtin(name: &str) -> Result<Profile, ProfileError> {
        let text = match name {
            "ideal" => return Ok(Profile::ideal()),
            "nominal" => include_str!("../profiles/nominal.toml"),
            "degraded" => include_str!("../profiles/degraded.toml"),
            _ => return Err(ProfileError::Unknown(name.into())),
        };
        Profile::from_toml(name, text)
    }

    /// A profile by name (`ideal`, `nominal`, `degraded`) or from a TOML file (named by its stem unless it names
    /// itself) that `read` reads (this crate does no IO): how `vb eval --perception`, Python and `vb-submit validate`
    /// take one.
    pub fn resolve(
        spec: &str,
        read: impl FnOnce(&std::path::Path) -> std::io::Result<String>,
    ) -> Result<Profile, ProfileError> {
        if BUILTIN.contains(&spec) {
            return Profile::builtin(spec);
        }
        let path = std::path::Path::new(spec);
        let file = |message: String| ProfileError::File {
            path: path.display().to_string(),
            message,
        };
        let text = match read(path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                return Err(ProfileError::Unknown(spec.into()))
            }
            Err(e) => return Err(file(e.to_string())),
        };
        let stem = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("custom");
        Profile::from_toml(stem, &text).map_err(|e| file(e.to_string()))
    }

    /// A profile from TOML text; `default_name` names it when the text gives no `name`.
    pub fn from_toml(default_name: &str, text: &str) -> Result<Profile, ProfileError> {
        let mut p: Profile = toml::from_str(text).map_err(|e| ProfileError::Toml(e.to_string()))?;
        if p.name.is_empty() {
            p.name = default_name.to_string();
        }
        p.validate()?;
        Ok(p)
    }

    /// Whether the planner sees the truth (every channel off, whatever the name).
    pub fn is_ideal(&self) -> bool {
        Profile {
            name: String::new(),
            ..self.clone()
        } == Profile::default()
    }

    /// Whether any map channel is degraded (an online elevation map, semantic errors, imperfect obstacle
    /// detection): then only planners that read no ground-truth maps may run under it.
    pub fn degrades_maps(&self) -> bool {
        self.elevation.online
            || self.semantics.error_rate > 0.0
            || self.semantics.confusion.is_some()
            || self.obstacles != ObstacleNoise::default()
    }

    /// The profile's identity, as results carry it ([`contracts::PerceptionId`]).
    pub fn id(&self) -> contracts::PerceptionId {
        contracts::PerceptionId::new(self.identity())
    }

    /// The profile's identity: its name and a hash of its parameters, `nominal@1f2e...` (16 hex digits of FNV-1a
    /// over the canonical JSON). `ideal` is just `ideal`.
    pub fn identity(&self) -> String {
        if self.is_ideal() && self.name == "ideal" {
            return "ideal".into();
        }
        format!("{}@{:016x}", self.name, self.hash())
    }

    /// The profile's parameters as canonical JSON (what its hash is over): how the service carries a profile to
    /// its workers.
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// A profile from [`Profile::to_json`]'s text, validated as a TOML file is.
    pub fn from_json(text: &str) -> Result<Profile, ProfileError> {
        let p: Profile =
            serde_json::from_str(text).map_err(|e| ProfileError::Toml(e.to_string()))?;
        p.validate()?;
        Ok(p)
    }

    /// FNV-1a 64 of the profile's canonical JSON (field order is the structs'; floats round-trip exactly).
    pub fn hash(&self) -> u64 {
        self.to_json().bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
            (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3)
        })
    }

    fn validate(&self) -> Result<(), ProfileError> {
        let s = &self.state;
        let e = &self.elevation;
        let o = &self.obstacles;
        let a = &self.actuation;
        let non_negative: [(&'static str, f64); 15] = [
            ("state.drift_share", s.drift_share),
            ("state.yaw_drift_deg_per_s", s.yaw_drift_deg_per_s),
            ("state.position_sigma", s.position_sigma),
            ("state.velocity_sigma", s.velocity_sigma),
            ("state.velocity_bias", s.velocity_bias),
            ("state.rate_sigma_deg", s.rate_sigma_deg),
            ("state.rate_bias_deg", s.rate_bias_deg),
            ("elevation.range", e.range),
            ("elevation.mount_height", e.mount_height),
            ("elevation.height_noise_k", e.height_noise_k),
            ("obstacles.detection_half_range", o.detection_half_range),
            (
                "obstacles.false_positives_per_update",
                o.false_positives_per_update,
            ),
            ("actuation.steering_bias_deg", a.steering_bias_deg),
            ("actuation.throttle_gain_spread", a.throttle_gain_spread),
            ("actuation.lag_s", a.lag_s),
        ];
        for (field, value) in non_negative {
            if !(value.is_finite() && value >= 0.0) {
                return Err(ProfileError::Range {
                    field,
                    value,
                    rule: "must be a finite number >= 0",
                });
            }
        }
        let unit: [(&'static str, f64); 2] = [
            ("semantics.error_rate", self.semantics.error_rate),
            ("obstacles.detection_max", o.detection_max),
        ];
        for (field, value) in unit {
            if !(0.0..=1.0).contains(&value) {
                return Err(ProfileError::Range {
                    field,
                    value,
                    rule: "must be in [0, 1]",
                });
            }
        }
        if a.throttle_gain_spread > 1.0 {
            return Err(ProfileError::Range {
                field: "actuation.throttle_gain_spread",
                value: a.throttle_gain_spread,
                rule: "must be at most 1 (a gain below zero would reverse the throttle)",
            });
        }
        if e.online {
            let online: [(&'static str, f64, &'static str); 3] = [
                ("elevation.range", e.range, "must be > 0 for an online map"),
                (
                    "elevation.update_hz",
                    e.update_hz,
                    "must be > 0 for an online map",
                ),
                (
                    "elevation.fov_deg",
                    e.fov_deg,
                    "must be > 0 for an online map",
                ),
            ];
            for (field, value, rule) in online {
                if !(value.is_finite() && value > 0.0) {
                    return Err(ProfileError::Range { field, value, rule });
                }
            }
            if e.fov_deg > 360.0 {
                return Err(ProfileError::Range {
                    field: "elevation.fov_deg",
                    value: e.fov_deg,
                    rule: "must be at most 360",
                });
            }
        }
        if let Some(m) = &self.semantics.confusion {
            check_confusion(m)?;
        }
        Ok(())
    }
}

fn check_confusion(m: &[Vec<f64>]) -> Result<(), ProfileError> {
    if m.len() != 10 {
        return Err(ProfileError::Confusion(format!("{} rows", m.len())));
    }
    for (i, row) in m.iter().enumerate() {
        let sum: f64 = row.iter().sum();
        if row.len() != 10
            || row.iter().any(|p| !(p.is_finite() && *p >= 0.0))
            || (sum - 1.0).abs() > 1e-6
        {
            return Err(ProfileError::Confusion(format!(
                "row {i}: {} entries summing to {sum}",
                row.len()
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Names are the built-ins; anything else is a file the caller reads (the crate does no IO).
    #[test]
    fn resolve_takes_names_and_files_the_caller_reads() {
        let nominal = Profile::resolve("nominal", |_| unreachable!("a built-in reads no file"));
        assert_eq!(nominal.unwrap(), Profile::builtin("nominal").unwrap());
        let dusty = Profile::resolve("dusty.toml", |_| {
            Ok("[state]\nposition_sigma = 0.5\n".into())
        });
        assert_eq!(dusty.unwrap().name, "dusty", "named by its stem");
        let e = Profile::resolve("foggy", |_| Err(std::io::ErrorKind::NotFound.into()));
        assert!(e
            .unwrap_err()
            .to_string()
            .contains("unknown perception profile `foggy`"));
        let e = Profile::resolve("bad.toml", |_| Ok("[state]\nposition_sigma = -1\n".into()));
        let e = e.unwrap_err().to_string();
        assert!(
            e.contains("bad.toml") && e.contains("position_sigma"),
            "{e}"
        );
    }

    /// The service carries a profile to its workers as JSON: the round trip keeps every parameter and the identity,
    /// and a tampered one is validated like a file.
    #[test]
    fn json_round_trips_exactly_and_is_validated() {
        for n in BUILTIN {
            let p = Profile::builtin(n).unwrap();
            let back = Profile::from_json(&p.to_json()).unwrap();
            assert_eq!(back, p);
            assert_eq!(back.identity(), p.identity());
        }
        let bad = Profile::builtin("nominal")
            .unwrap()
            .to_json()
            .replace("\"range\":", "\"range\":-");
        assert!(Profile::from_json(&bad).is_err(), "{bad}");
        assert!(Profile::from_json("{\"nonsense\": 1}").is_err());
    }

    #[test]
    fn builtins_parse_and_have_distinct_identities() {
        let ids: Vec<String> = BUILTIN
            .iter()
            .map(|n| Profile::builtin(n).unwrap().identity())
            .collect();
        assert_eq!(ids[0], "ideal");
        assert!(ids[1].starts_with("nominal@") && ids[2].starts_with("degraded@"));
        assert!(Profile::ideal().is_ideal());
        assert!(!Profile::builtin("nominal").unwrap().is_ideal());
        // A parameter changed is another profile, under the same name.
        let mut p = Profile::builtin("nominal").unwrap();
        p.state.position_sigma += 0.01;
        assert_ne!(p.identity(), ids[1]);
    }

    #[test]
    fn a_file_names_only_what_it_degrades_and_bad_values_are_refused() {
        let p = Profile::from_toml("gnss-only", "[state]\nposition_sigma = 0.3\n").unwrap();
        assert_eq!(p.name, "gnss-only");
        assert_eq!(p.state.position_sigma, 0.3);
        assert_eq!(p.obstacles, ObstacleNoise::default());
        for (text, says) in [
            (
                "[state]\nposition_sigma = -1\n",
                "state.position_sigma = -1",
            ),
            ("[state]\nposition_sigmaa = 1\n", "unknown field"),
            ("[semantics]\nerror_rate = 1.5\n", "must be in [0, 1]"),
            ("[elevation]\nonline = true\n", "elevation.range = 0"),
            ("[semantics]\nconfusion = [[1.0]]\n", "10 x 10"),
            ("[actuation]\nthrottle_gain_spread = 2\n", "at most 1"),
        ] {
            let e = Profile::from_toml("x", text).unwrap_err().to_string();
            assert!(e.contains(says), "{text:?}: {e}");
        }
        assert!(matches!(
            Profile::builtin("foggy"),
            Err(ProfileError::Unknown(_))
        ));
    }
}
