//! The noise's randomness: one ChaCha stream per episode and channel, a pure function of the task, the run's seed
//! and the profile, so every submission meets the same noise on the same task (paired comparisons stay valid) and a
//! channel switched on or off leaves the others' draws unchanged.

use contracts::TaskId;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

/// What one episode's noise is a function of.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EpisodeKey {
    pub task: TaskId,
    pub seed: u64,
    /// [`crate::Profile::hash`].
    pub profile: u64,
}

/// The perception channels, each with its own stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    State = 1,
    Elevation = 2,
    Semantics = 3,
    Obstacles = 4,
    Actuation = 5,
}

/// SplitMix64's finaliser: a bijective mix of 64 bits.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The stream of `channel` in episode `key`.
pub fn stream(key: &EpisodeKey, channel: Channel) -> ChaCha8Rng {
    let words = [
        mix(u64::from(key.task.world) << 32 | u64::from(key.task.index)),
        mix(key.seed ^ 0x7065_7263_6570_7431),
        mix(key.profile),
        mix(channel as u64),
    ];
    let mut seed = [0u8; 32];
    for (k, w) in words.iter().enumerate() {
        seed[8 * k..8 * k + 8].copy_from_slice(&w.to_le_bytes());
    }
    ChaCha8Rng::from_seed(seed)
}

/// A standard normal draw (rand_distr's ziggurat: a table lookup for almost every draw, `exp` and `ln` in the
/// tails; the same sequence on every machine).
pub fn normal(rng: &mut ChaCha8Rng) -> f64 {
    use rand::Rng;
    rng.sample::<f64, _>(rand_distr::StandardNormal)
}

/// A uniform draw in [0, 1).
pub fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    use rand::Rng;
    rng.gen::<f64>()
}

/// +1 or -1 with equal probability.
pub fn sign(rng: &mut ChaCha8Rng) -> f64 {
    if uniform(rng) < 0.5 {
        -1.0
    } else {
        1.0
    }
}
