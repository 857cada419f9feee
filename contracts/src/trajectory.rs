//! The one trajectory codec: a recorded trajectory as CSV text with a header that names each column and its unit
//! (angles in degrees). The worker sends it (gzip-compressed), the store keeps it, the leaderboard draws it and
//! `vb sim run` writes it; all through [`to_csv`] and [`from_csv`]. Pure text: no IO.

use crate::TrajectorySample;
use std::fmt::Write as _;

/// The header [`to_csv`] writes.
pub const CSV_HEADER: &str =
    "time_s,x_m,y_m,z_m,roll_deg,pitch_deg,yaw_deg,speed_mps,throttle,steering,brake";

/// A trajectory text that cannot be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrajectoryError {
    #[error("trajectory CSV: no header")]
    NoHeader,
    #[error("trajectory CSV: no column `{0}`")]
    MissingColumn(&'static str),
    #[error("trajectory CSV line {line}: {message}")]
    BadLine { line: usize, message: String },
}

/// The trajectory as CSV (header [`CSV_HEADER`], one line per sample).
pub fn to_csv(samples: &[TrajectorySample]) -> String {
    let mut s = String::with_capacity(CSV_HEADER.len() + 1 + samples.len() * 72);
    s.push_str(CSV_HEADER);
    s.push('\n');
    for t in samples {
        // Writing into a String cannot fail.
        let _ = writeln!(
            s,
            "{:.3},{:.4},{:.4},{:.4},{:.3},{:.3},{:.3},{:.4},{:.4},{:.4},{:.4}",
            t.time,
            t.x,
            t.y,
            t.z,
            t.roll.to_degrees(),
            t.pitch.to_degrees(),
            t.yaw.to_degrees(),
            t.speed,
            t.throttle,
            t.steering,
            t.brake
        );
    }
    s
}

/// Reads a trajectory written by [`to_csv`], columns found by name (in any order). Also reads the headers older
/// stores hold (`time,x,...`, angles in radians), so their episodes still draw.
pub fn from_csv(text: &str) -> Result<Vec<TrajectorySample>, TrajectoryError> {
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .ok_or(TrajectoryError::NoHeader)?
        .split(',')
        .map(str::trim)
        .collect();
    // (names in the current header, the older one), and whether the older one held radians.
    let find = |now: &'static str, old: &'static str| {
        header
            .iter()
            .position(|h| *h == now)
            .map(|i| (i, false))
            .or_else(|| header.iter().position(|h| *h == old).map(|i| (i, true)))
            .ok_or(TrajectoryError::MissingColumn(now))
    };
    let cols = [
        find("time_s", "time")?,
        find("x_m", "x")?,
        find("y_m", "y")?,
        find("z_m", "z")?,
        find("roll_deg", "roll")?,
        find("pitch_deg", "pitch")?,
        find("yaw_deg", "yaw")?,
        find("speed_mps", "speed")?,
        find("throttle", "throttle")?,
        find("steering", "steering")?,
        find("brake", "brake")?,
    ];
    let mut out = Vec::new();
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').collect();
        let mut v = [0.0f64; 11];
        for (k, &(i, _)) in cols.iter().enumerate() {
            let cell = cells.get(i).ok_or_else(|| TrajectoryError::BadLine {
                line: n + 2,
                message: format!("{} cells, header has {}", cells.len(), header.len()),
            })?;
            v[k] = cell.trim().parse().map_err(|e| TrajectoryError::BadLine {
                line: n + 2,
                message: format!("`{cell}`: {e}"),
            })?;
        }
        // Angles: degrees in the current header, radians in the older one.
        let angle = |k: usize| if cols[k].1 { v[k] } else { v[k].to_radians() };
        out.push(TrajectorySample {
            time: v[0],
            x: v[1],
            y: v[2],
            z: v[3],
            roll: angle(4),
            pitch: angle(5),
            yaw: angle(6),
            speed: v[7],
            throttle: v[8],
            steering: v[9],
            brake: v[10],
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(k: f64) -> TrajectorySample {
        TrajectorySample {
            time: 0.1 * k,
            x: 1.5 + k,
            y: -2.25 * k,
            z: 0.5,
            roll: 0.1 * k,
            pitch: -0.05,
            yaw: 3.0 - k,
            speed: 4.0,
            throttle: 0.5,
            steering: -0.25,
            brake: 0.0,
        }
    }

    #[test]
    fn round_trips_to_the_printed_precision() {
        let s: Vec<_> = (0..5).map(|k| sample(k as f64)).collect();
        let back = from_csv(&to_csv(&s)).unwrap();
        assert_eq!(back.len(), 5);
        for (a, b) in s.iter().zip(&back) {
            assert!((a.x - b.x).abs() < 1e-4 && (a.y - b.y).abs() < 1e-4);
            // 0.001 degree.
            assert!((a.roll - b.roll).abs() < 2e-5 && (a.yaw - b.yaw).abs() < 2e-5);
            assert_eq!((a.throttle, a.steering), (b.throttle, b.steering));
        }
    }

    #[test]
    fn reads_the_older_header_in_radians_and_refuses_broken_text() {
        let old = "time,x,y,z,roll,pitch,yaw,speed,throttle,steering,brake\n0.10,1.000,2.000,0.500,0.1000,-0.0500,3.0000,4.000,0.500,-0.250,0.000\n";
        let t = from_csv(old).unwrap();
        assert_eq!(t.len(), 1);
        assert!((t[0].roll - 0.1).abs() < 1e-12 && (t[0].x - 1.0).abs() < 1e-12);
        assert_eq!(from_csv(""), Err(TrajectoryError::NoHeader));
        assert_eq!(
            from_csv("time_s,x_m\n"),
            Err(TrajectoryError::MissingColumn("y_m"))
        );
        assert!(matches!(
            from_csv(&format!("{CSV_HEADER}\n1,2,3\n")),
            Err(TrajectoryError::BadLine { line: 2, .. })
        ));
    }
}
