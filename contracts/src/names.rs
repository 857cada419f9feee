//! Names that cross crates as their own types, so that a vehicle can never be passed where a planner or a simulator
//! version is wanted: [`SimVersion`] (`sim-core 0.1.0 r10`), [`VehicleId`] (`hmmwv`) and [`PlannerName`] (`pid`,
//! or a submission's `endpoint:...`). Each is its text, unchanged: serde writes it as a plain string, so files, rows
//! and APIs hold exactly what they held when these were `String`s.

macro_rules! text_name {
    ($(#[$meta:meta])* $name:ident) => {
        $(#[$meta])*
        #[derive(Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize)]
        #[serde(transparent)]
        pub struct $name(String);

        impl $name {
            pub fn new(text: impl Into<String>) -> $name {
                $name(text.into())
            }

            pub fn as_str(&self) -> &str {
                &self.0
            }

            pub fn into_string(self) -> String {
                self.0
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(&self.0)
            }
        }

        impl std::ops::Deref for $name {
            type Target = str;

            fn deref(&self) -> &str {
                &self.0
            }
        }

        impl AsRef<str> for $name {
            fn as_ref(&self) -> &str {
                &self.0
            }
        }

        impl std::borrow::Borrow<str> for $name {
            fn borrow(&self) -> &str {
                &self.0
            }
        }

        impl From<&str> for $name {
            fn from(text: &str) -> $name {
                $name(text.to_string())
            }
        }

        impl From<String> for $name {
            fn from(text: String) -> $name {
                $name(text)
            }
        }

        impl From<&String> for $name {
            fn from(text: &String) -> $name {
                $name(text.clone())
            }
        }

        impl From<$name> for String {
            fn from(name: $name) -> String {
                name.0
            }
        }

        impl std::str::FromStr for $name {
            type Err = std::convert::Infallible;

            fn from_str(text: &str) -> Result<$name, Self::Err> {
                Ok($name(text.to_string()))
            }
        }

        impl PartialEq<str> for $name {
            fn eq(&self, other: &str) -> bool {
                self.0 == other
            }
        }

        impl PartialEq<&str> for $name {
            fn eq(&self, other: &&str) -> bool {
                self.0 == *other
            }
        }

        impl PartialEq<String> for $name {
            fn eq(&self, other: &String) -> bool {
                &self.0 == other
            }
        }

        impl PartialEq<$name> for String {
            fn eq(&self, other: &$name) -> bool {
                self == &other.0
            }
        }

        impl PartialEq<$name> for str {
            fn eq(&self, other: &$name) -> bool {
                self == other.0
            }
        }
    };
}

text_name!(
    /// The perception profile a run's planner saw the world through: `ideal` (ground truth, the default), or a
    /// profile's name and parameter hash (`nominal@1f2e3d4c5b6a7980`, the `perception` crate's
    /// `Profile::identity`). Runs under different profiles are different runs.
    PerceptionId
);

impl PerceptionId {
    /// Ground truth.
    pub fn ideal() -> PerceptionId {
        PerceptionId::new("ideal")
    }

    /// Whether this is ground truth (rows under it omit the field, so they read as they always have).
    pub fn is_ideal(&self) -> bool {
        self.as_str() == "ideal"
    }
}

impl Default for PerceptionId {
    fn default() -> PerceptionId {
        PerceptionId::ideal()
    }
}

macro_rules! empty_default {
    ($($name:ident),*) => {
        $(impl Default for $name {
            fn default() -> $name {
                $name(String::new())
            }
        })*
    };
}

empty_default!(SimVersion, VehicleId, PlannerName);

text_name!(
    /// The simulator's version as results carry it (sim-core's `SIM_VERSION`, e.g. `sim-core 0.1.0 r10`): rows of
    /// different versions are different runs.
    SimVersion
);

text_name!(
    /// A vehicle's name, as `sim-core/vehicles/` names its files (`hmmwv`).
    VehicleId
);

text_name!(
    /// A planner's name in results: a built-in's (`pid`, `mppi6`) or what a submission's rows record.
    PlannerName
);

#[cfg(test)]
mod tests {
    use super::*;

    /// The types change nothing on the wire: each is written and read as its plain text.
    #[test]
    fn written_and_read_as_plain_text() {
        let v = SimVersion::new("sim-core 0.1.0 r10");
        assert_eq!(serde_json::to_string(&v).unwrap(), "\"sim-core 0.1.0 r10\"");
        assert_eq!(
            serde_json::from_str::<VehicleId>("\"hmmwv\"").unwrap(),
            "hmmwv"
        );
        assert_eq!(PlannerName::from("pid").to_string(), "pid");
        assert!(serde_json::from_str::<PlannerName>("3").is_err());
    }
}
