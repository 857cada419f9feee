//! What the ground is made of: the world's generation factors, the semantic classes of its patches and their
//! physical surfaces (rigid friction or soil parameters).

use serde::{Deserialize, Serialize};

pub use contracts::{ElevationLevel, ObstacleDensity, SemanticsKind};

/// The ten semantic classes. The discriminants are the label ids of the original release.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[repr(u8)]
pub enum Semantic {
    Clay = 0,
    Concrete = 1,
    Dirt = 2,
    Grass = 3,
    Gravel = 4,
    Rock = 5,
    Wood = 6,
    Mud = 7,
    Sand = 8,
    Snow = 9,
}

impl Semantic {
    pub const ALL: [Semantic; 10] = [
        Self::Clay,
        Self::Concrete,
        Self::Dirt,
        Self::Grass,
        Self::Gravel,
        Self::Rock,
        Self::Wood,
        Self::Mud,
        Self::Sand,
        Self::Snow,
    ];
    pub const RIGID: [Semantic; 7] = [
        Self::Clay,
        Self::Concrete,
        Self::Dirt,
        Self::Grass,
        Self::Gravel,
        Self::Rock,
        Self::Wood,
    ];
    pub const DEFORMABLE: [Semantic; 3] = [Self::Mud, Self::Sand, Self::Snow];

    pub fn from_id(id: u8) -> Option<Semantic> {
        Self::ALL.get(id as usize).copied()
    }
    pub fn id(self) -> u8 {
        self as u8
    }
    pub fn is_deformable(self) -> bool {
        matches!(self, Self::Mud | Self::Sand | Self::Snow)
    }
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Clay => "clay",
            Self::Concrete => "concrete",
            Self::Dirt => "dirt",
            Self::Grass => "grass",
            Self::Gravel => "gravel",
            Self::Rock => "rock",
            Self::Wood => "wood",
            Self::Mud => "mud",
            Self::Sand => "sand",
            Self::Snow => "snow",
        }
    }
    /// Friction distribution (mean, standard deviation) of a rigid class, as in the release; `None` if deformable.
    pub fn friction_distribution(self) -> Option<(f64, f64)> {
        Some(match self {
            Self::Clay => (0.60, 0.05),
            Self::Concrete => (0.85, 0.08),
            Self::Dirt => (0.60, 0.10),
            Self::Grass => (0.36, 0.07),
            Self::Gravel => (0.55, 0.10),
            Self::Rock => (0.65, 0.08),
            Self::Wood => (0.45, 0.06),
            _ => return None,
        })
    }
    /// Soil Contact Model parameters of a deformable class (snow = Chrono Soft, mud = Mid, sand = Hard/LETE).
    pub fn soil(self) -> Option<SoilParams> {
        match self {
            Self::Snow => Some(SoilParams::SNOW),
            Self::Mud => Some(SoilParams::MUD),
            Self::Sand => Some(SoilParams::SAND),
            _ => None,
        }
    }
}

/// Soil Contact Model (Bekker-Wong / Janosi-Hanamoto) parameters, Chrono's units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoilParams {
    /// Bekker frictional modulus K_phi, Pa/m^n (N/m^(n+2)).
    pub k_phi: f64,
    /// Bekker cohesive modulus K_c, N/m^(n+1).
    pub k_c: f64,
    /// Sinkage exponent n.
    pub n: f64,
    /// Cohesion c, Pa.
    pub cohesion: f64,
    /// Internal friction angle phi, degrees.
    pub friction_angle_deg: f64,
    /// Janosi-Hanamoto shear deformation modulus K, m.
    pub janosi_k: f64,
    /// Elastic (unloading) stiffness K_e, Pa/m.
    pub elastic_k: f64,
    /// Vertical damping R, Pa s/m.
    pub damping: f64,
}

impl SoilParams {
    /// Chrono "Soft" preset, Verti-Bench "snow".
    pub const SNOW: SoilParams = SoilParams {
        k_phi: 0.2e6,
        k_c: 0.0,
        n: 1.1,
        cohesion: 0.0,
        friction_angle_deg: 30.0,
        janosi_k: 0.01,
        elastic_k: 4e7,
        damping: 3e4,
    };
    /// Chrono "Mid" preset, Verti-Bench "mud".
    pub const MUD: SoilParams = SoilParams {
        k_phi: 2e6,
        k_c: 0.0,
        n: 1.1,
        cohesion: 0.0,
        friction_angle_deg: 30.0,
        janosi_k: 0.01,
        elastic_k: 2e8,
        damping: 3e4,
    };
    /// Chrono "Hard" preset (LETE sand), Verti-Bench "sand".
    pub const SAND: SoilParams = SoilParams {
        k_phi: 5.301e6,
        k_c: 1.02e5,
        n: 0.793,
        cohesion: 1.3e3,
        friction_angle_deg: 31.1,
        janosi_k: 0.012,
        elastic_k: 4e8,
        damping: 3e4,
    };
}

/// The physical surface of one semantic patch.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Surface {
    /// Rigid ground with a Coulomb friction coefficient (combined with the tyre's as the minimum).
    Rigid { friction: f64 },
    /// Deformable ground simulated with the Soil Contact Model.
    Deformable { soil: SoilParams },
}

/// One semantic patch: its class and its own sampled physical surface.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Patch {
    pub semantic: Semantic,
    pub surface: Surface,
}

/// Restitution of rigid ground, as in the release.
pub const RIGID_RESTITUTION: f64 = 0.01;
