//! Learned kinodynamic models (`KINO.md`): what they see ([`features`]), the crop model ([`net::KinoNet`],
//! `vertibench-kino-v1`) and the terrain-attentive model ([`tal::TalNet`], `vertibench-tal-v1`), for the hybrid
//! planners that roll them out ([`mppi::KinoMppi`]), and the traversability estimator whose grid `tnt` adds to their
//! cost ([`tnt::TravNet`], `vertibench-tnt-v1`).

pub mod features;
pub mod mppi;
pub mod net;
pub mod tal;
pub mod tnt;

pub use mppi::{KinoMppi, KinoMppiConfig, Rollout};
pub use net::KinoNet;
pub use tal::TalNet;
pub use tnt::TravNet;

use crate::net::WeightsError;
use features::{Pose, FEATURES};
use sim_core::world::World;
use std::collections::BTreeMap;

/// A learned model a sampling planner rolls out.
#[derive(Clone, Debug)]
pub enum Dynamics {
    /// A crop of the world under and ahead of every predicted pose (`mppi6`, `wmvct`).
    Crop(KinoNet),
    /// One map per decision, attended to by every predicted pose's offset from it (`tal`).
    Attention(TalNet),
}

impl Dynamics {
    /// A weights file's bytes, by its `format`: `vertibench-tal-v1` or else `vertibench-kino-v1`.
    pub fn from_bytes(bytes: &[u8]) -> Result<Dynamics, WeightsError> {
        if crate::nn::format(bytes).as_deref() == Some(tal::TAL_LAYOUT) {
            TalNet::from_bytes(bytes).map(Dynamics::Attention)
        } else {
            KinoNet::from_bytes(bytes).map(Dynamics::Crop)
        }
    }

    /// Whether a weights file's `format` is one of these models'.
    pub fn is_model_format(bytes: &[u8]) -> bool {
        matches!(
            crate::nn::format(bytes).as_deref(),
            Some(features::LAYOUT | tal::TAL_LAYOUT)
        )
    }

    pub fn metadata(&self) -> &BTreeMap<String, String> {
        match self {
            Dynamics::Crop(n) => n.metadata(),
            Dynamics::Attention(n) => n.metadata(),
        }
    }

    pub fn sha256(&self) -> &str {
        match self {
            Dynamics::Crop(n) => n.sha256(),
            Dynamics::Attention(n) => n.sha256(),
        }
    }

    pub fn members(&self) -> usize {
        match self {
            Dynamics::Crop(n) => n.members(),
            Dynamics::Attention(n) => n.members(),
        }
    }

    /// A decision starts at `pose`: the attentive model takes and encodes its map there.
    pub fn begin(&mut self, world: &World, pose: &Pose, scale: f64) {
        if let Dynamics::Attention(n) = self {
            n.set_anchor(world, pose, scale);
        }
    }

    /// Every member's scaled outputs (`members x 7` into `out`) for a vehicle at `pose` with `vector` features.
    pub fn predict(
        &mut self,
        world: &World,
        pose: &Pose,
        scale: f64,
        vector: &[f32; FEATURES.len()],
        out: &mut [f32],
    ) {
        match self {
            Dynamics::Crop(n) => n.predict_at(world, pose, scale, vector, out),
            Dynamics::Attention(n) => n.predict_at(pose, vector, out),
        }
    }
}

impl From<KinoNet> for Dynamics {
    fn from(n: KinoNet) -> Self {
        Dynamics::Crop(n)
    }
}

impl From<TalNet> for Dynamics {
    fn from(n: TalNet) -> Self {
        Dynamics::Attention(n)
    }
}

/// The model of a weights file (either layout).
pub fn load(path: &std::path::Path) -> Result<Dynamics, crate::LearnedError> {
    crate::builtin::read_weights(path, Dynamics::from_bytes)
}
