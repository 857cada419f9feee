//! The stuck rule's bookkeeping, one state per [`StuckRule`]: the displacement rule keeps the chassis' positions
//! every [`SAMPLE_DT`] over its window in a ring; the speed rule keeps when the vehicle was last fast enough.

use crate::episode::StuckRule;

/// How often the displacement rule samples the position, s.
const SAMPLE_DT: f64 = 0.5;

#[derive(Clone, Debug)]
pub(crate) enum StuckWatch {
    Displacement {
        /// Stuck below this displacement over the window, m at the world's scale.
        distance: f64,
        window: f64,
        /// Physics steps between two samples.
        sample_every: u64,
        ring: Vec<[f64; 2]>,
        /// Samples taken so far.
        count: usize,
    },
    Speed {
        /// Stuck below this speed (m/s, unscaled) for the whole window.
        speed: f64,
        window: f64,
        /// When the vehicle was last at least that fast, s.
        fast_at: f64,
    },
}

impl StuckWatch {
    /// The bookkeeping of `rule` in a world of `scale`, physics step `dt`.
    pub(crate) fn new(rule: StuckRule, scale: f64, dt: f64) -> StuckWatch {
        match rule {
            StuckRule::Displacement { distance, window } => {
                let len = (window / SAMPLE_DT).round() as usize + 1;
                StuckWatch::Displacement {
                    distance: distance * scale,
                    window,
                    sample_every: (SAMPLE_DT / dt).round().max(1.0) as u64,
                    ring: vec![[0.0; 2]; len.max(2)],
                    count: 0,
                }
            }
            StuckRule::Speed { speed, window } => StuckWatch::Speed {
                speed,
                window,
                fast_at: 0.0,
            },
        }
    }

    /// After physics step `step` (at `time`, s), with the chassis at `pos` moving at `speed`: why the vehicle is
    /// stuck, if it is. Allocates only then.
    pub(crate) fn check(
        &mut self,
        step: u64,
        time: f64,
        pos: [f64; 2],
        speed: f64,
    ) -> Option<String> {
        match self {
            StuckWatch::Displacement {
                distance,
                window,
                sample_every,
                ring,
                count,
            } => {
                if !step.is_multiple_of(*sample_every) {
                    return None;
                }
                let len = ring.len();
                ring[*count % len] = pos;
                *count += 1;
                if *count < len {
                    return None;
                }
                let old = ring[*count % len];
                ((pos[0] - old[0]).hypot(pos[1] - old[1]) < *distance)
                    .then(|| format!("moved less than {distance:.2} m in {window} s"))
            }
            StuckWatch::Speed {
                speed: limit,
                window,
                fast_at,
            } => {
                if speed.abs() >= *limit {
                    *fast_at = time;
                    None
                } else if time - *fast_at >= *window {
                    Some(format!("speed below {limit} m/s for {window} s"))
                } else {
                    None
                }
            }
        }
    }
}
