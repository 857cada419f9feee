//! Our datasheets beside a reference's (`vb sim characterize --reference FILE`): every figure of both, their
//! ratio and whether ours is within tolerance (issue 59, item 2): grades and tilt angles within 4 degrees, every
//! other figure within 20%. The reference is JSON in `vb sim characterize --json`'s schema (`{"datasheets":
//! [...]}`), as the Chrono reference harness writes it; a figure the reference leaves out (or sets to null) is
//! listed as not compared. A reference may also hold the move-off check start by start (`{"move_off": {"tasks":
//! [{"task": "w001-t0", "distance": 12.3}, ...]}}`, the harness's `move-off`), read by [`move_off`].

use serde_json::Value;

/// Tolerance of grades and tilt angles, degrees.
pub const ANGLE_TOLERANCE_DEG: f64 = 4.0;
/// Relative tolerance of every other figure.
pub const RELATIVE_TOLERANCE: f64 = 0.2;

/// Why a reference could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    #[error("the reference is not JSON: {0}")]
    Json(#[from] serde_json::Error),
    #[error("the reference has no `datasheets` list (the schema of `vb sim characterize --json`)")]
    NoDatasheets,
    #[error("reference datasheet {0} has no `surface`")]
    NoSurface(usize),
    #[error("the reference's move_off.tasks[{index}] is not {{\"task\": \"wNNN-tK\", \"distance\": metres}}: {why}")]
    BadMoveOff { index: usize, why: String },
}

/// How a figure is compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Tolerance {
    /// Within [`ANGLE_TOLERANCE_DEG`] degrees.
    Angle,
    /// Within [`RELATIVE_TOLERANCE`] of the reference.
    Relative,
}

/// One figure of one surface, ours beside the reference's.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Comparison {
    pub surface: String,
    pub figure: String,
    pub ours: Option<f64>,
    pub reference: Option<f64>,
    pub tolerance: Tolerance,
}

impl Comparison {
    /// Ours over the reference, when both exist and the reference is not zero.
    pub fn ratio(&self) -> Option<f64> {
        match (self.ours, self.reference) {
            (Some(o), Some(r)) if r != 0.0 => Some(o / r),
            _ => None,
        }
    }

    /// Whether ours is within tolerance; `None` when either figure is missing.
    pub fn within(&self) -> Option<bool> {
        let (o, r) = (self.ours?, self.reference?);
        Some(match self.tolerance {
            Tolerance::Angle => (o - r).abs() <= ANGLE_TOLERANCE_DEG,
            Tolerance::Relative if r == 0.0 => o.abs() <= 1e-9,
            Tolerance::Relative => ((o - r) / r).abs() <= RELATIVE_TOLERANCE,
        })
    }
}

/// The compared figures of a datasheet (as `vb sim characterize --json` writes it): name, value, tolerance.
fn figures(sheet: &Value) -> Vec<(String, Option<f64>, Tolerance)> {
    use Tolerance::{Angle, Relative};
    let num = |k: &str| sheet.get(k).and_then(Value::as_f64);
    let mut out = vec![
        (
            "static_sinkage".to_string(),
            num("static_sinkage"),
            Relative,
        ),
        ("ride_height".to_string(), num("ride_height"), Relative),
    ];
    for (i, t) in [2, 5, 10, 20].iter().enumerate() {
        let v = sheet
            .get("speed_at")
            .and_then(|a| a.get(i))
            .and_then(|p| p.get(1))
            .and_then(Value::as_f64);
        out.push((format!("speed_at_{t}s"), v, Relative));
    }
    for (k, tol) in [
        ("distance_20s", Relative),
        ("braking_decel_g", Relative),
        ("climb_grade_deg", Angle),
        ("slide_angle_deg", Angle),
        ("tip_angle_deg", Angle),
        ("turn_radius_half", Relative),
        ("turn_radius_full", Relative),
    ] {
        out.push((k.to_string(), num(k), tol));
    }
    out
}

/// Every figure of `ours` (our datasheets) beside the reference datasheet of the same surface in `reference_json`.
pub fn compare(ours: &[Value], reference_json: &str) -> Result<Vec<Comparison>, ReferenceError> {
    let reference: Value = serde_json::from_str(reference_json)?;
    let sheets = reference
        .get("datasheets")
        .and_then(Value::as_array)
        .ok_or(ReferenceError::NoDatasheets)?;
    let mut by_surface = Vec::new();
    for (i, s) in sheets.iter().enumerate() {
        let surface = s
            .get("surface")
            .and_then(Value::as_str)
            .ok_or(ReferenceError::NoSurface(i))?;
        by_surface.push((surface.to_string(), s));
    }
    let mut out = Vec::new();
    for sheet in ours {
        let surface = sheet.get("surface").and_then(Value::as_str).unwrap_or("");
        let theirs = by_surface
            .iter()
            .find(|(s, _)| s == surface)
            .map(|(_, v)| figures(v));
        for (j, (figure, value, tolerance)) in figures(sheet).into_iter().enumerate() {
            out.push(Comparison {
                surface: surface.to_string(),
                figure,
                ours: value,
                reference: theirs.as_ref().and_then(|t| t[j].1),
                tolerance,
            });
        }
    }
    Ok(out)
}

/// The comparison as a table, then a count of figures within tolerance.
pub fn table(rows: &[Comparison]) -> String {
    use std::fmt::Write as _;
    let mut s = format!(
        "{:<6} {:<17} {:>10} {:>10} {:>7}  {}\n",
        "ground", "figure", "ours", "reference", "ratio", "within (angles 4 deg, else 20%)"
    );
    let f = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.3}"));
    let (mut within, mut compared) = (0, 0);
    for r in rows {
        let verdict = match r.within() {
            Some(true) => "yes",
            Some(false) => "NO",
            None => "not compared",
        };
        if let Some(w) = r.within() {
            compared += 1;
            within += usize::from(w);
        }
        let _ = writeln!(
            s,
            "{:<6} {:<17} {:>10} {:>10} {:>7}  {verdict}",
            r.surface,
            r.figure,
            f(r.ours),
            f(r.reference),
            r.ratio().map_or("-".to_string(), |x| format!("{x:.3}"))
        );
    }
    let _ = writeln!(
        s,
        "{within} of {compared} compared figures within tolerance"
    );
    s
}

/// The reference's move-off check start by start (`move_off.tasks`), or `None` if it has none.
pub fn move_off(
    reference_json: &str,
) -> Result<Option<Vec<crate::move_off::StartDistance>>, ReferenceError> {
    let reference: Value = serde_json::from_str(reference_json)?;
    let Some(tasks) = reference.get("move_off").and_then(|m| m.get("tasks")) else {
        return Ok(None);
    };
    let bad = |index: usize, why: &str| ReferenceError::BadMoveOff {
        index,
        why: why.to_string(),
    };
    let list = tasks.as_array().ok_or_else(|| bad(0, "not a list"))?;
    let mut out = Vec::with_capacity(list.len());
    for (i, t) in list.iter().enumerate() {
        let task = t
            .get("task")
            .and_then(Value::as_str)
            .ok_or_else(|| bad(i, "no task id"))?
            .parse()
            .map_err(|e: contracts::TaskIdError| bad(i, &e.to_string()))?;
        let distance = t
            .get("distance")
            .and_then(Value::as_f64)
            .filter(|d| d.is_finite() && *d >= 0.0)
            .ok_or_else(|| bad(i, "no finite, non-negative distance"))?;
        out.push(crate::move_off::StartDistance { task, distance });
    }
    Ok(Some(out))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn sheet(surface: &str, grade: f64, distance: f64) -> Value {
        json!({
            "surface": surface, "static_sinkage": 0.1, "ride_height": 1.0,
            "speed_at": [[2.0, 5.0], [5.0, 10.0], [10.0, 20.0], [20.0, 25.0]],
            "distance_20s": distance, "braking_decel_g": 0.8, "climb_grade_deg": grade,
            "slide_angle_deg": null, "tip_angle_deg": 50.0, "turn_radius_half": 20.0, "turn_radius_full": 9.0
        })
    }

    #[test]
    fn angles_compare_within_4_degrees_and_the_rest_within_20_percent() {
        let ours = [sheet("snow", 26.0, 400.0), sheet("mud", 26.0, 480.0)];
        let reference = json!({ "datasheets": [sheet("snow", 18.0, 373.0)] }).to_string();
        let rows = compare(&ours, &reference).unwrap();
        let get = |s: &str, f: &str| {
            rows.iter()
                .find(|r| r.surface == s && r.figure == f)
                .unwrap()
        };
        assert_eq!(
            get("snow", "climb_grade_deg").within(),
            Some(false),
            "26 against 18 deg"
        );
        let d = get("snow", "distance_20s");
        assert_eq!(d.within(), Some(true));
        assert!((d.ratio().unwrap() - 400.0 / 373.0).abs() < 1e-12);
        assert_eq!(
            get("snow", "slide_angle_deg").within(),
            None,
            "null on both sides"
        );
        assert_eq!(
            get("mud", "distance_20s").within(),
            None,
            "no mud reference"
        );
        assert_eq!(get("snow", "speed_at_20s").within(), Some(true));
        let t = table(&rows);
        assert!(t.contains("NO") && t.contains("not compared"), "{t}");
        assert!(
            t.contains(" of 12 compared figures within tolerance"),
            "{t}"
        );
        // 21 % off is out; 19 % is in.
        let ours = [sheet("sand", 20.0, 121.0)];
        let reference = json!({ "datasheets": [sheet("sand", 23.9, 100.0)] }).to_string();
        let rows = compare(&ours, &reference).unwrap();
        let get = |f: &str| rows.iter().find(|r| r.figure == f).unwrap().within();
        assert_eq!(
            (get("distance_20s"), get("climb_grade_deg")),
            (Some(false), Some(true))
        );
    }

    #[test]
    fn the_move_off_check_pairs_start_by_start_and_counts_each_way_of_disagreeing() {
        use crate::move_off::{agreement, agreement_table, MoveOff, StartDistance};
        let id = |s: &str| s.parse::<contracts::TaskId>().unwrap();
        let start = |t: &str, d: f64| StartDistance {
            task: id(t),
            distance: d,
        };
        let ours = MoveOff {
            tasks: vec![
                start("w001-t0", 80.0),
                start("w001-t1", 1.0),
                start("w001-t2", 4.9),
                start("w001-t3", 5.0),
                start("w002-t0", 30.0),
            ],
        };
        let text = json!({"datasheets": [], "move_off": {"tasks": [
            {"task": "w001-t3", "distance": 0.2}, {"task": "w001-t0", "distance": 60.0},
            {"task": "w001-t1", "distance": 3.0}, {"task": "w001-t2", "distance": 12.0}
        ]}})
        .to_string();
        let reference = move_off(&text).unwrap().unwrap();
        assert_eq!(ours.stuck(), vec![id("w001-t1"), id("w001-t2")]);
        let a = agreement(&ours, &reference);
        assert_eq!(
            (
                a.both_moved,
                a.both_stranded,
                a.only_ours_stranded,
                a.only_reference_stranded
            ),
            (1, 1, 1, 1),
            "5.0 m is moved (the check's >= 5 m), 4.9 m is not"
        );
        assert_eq!(a.not_in_reference, vec![id("w002-t0")]);
        assert_eq!(a.starts[0].reference, 60.0, "paired by task, not by order");
        let t = agreement_table(&a);
        assert!(
            t.contains(
                "stranded only in ours 1, stranded only in the reference 1; 1 not in the reference"
            ),
            "{t}"
        );
        assert!(compare(&[], &text).unwrap().is_empty());
        // No move_off: none; a malformed row: refused, naming it.
        assert_eq!(move_off(r#"{"datasheets": []}"#).unwrap(), None);
        let e = move_off(
            r#"{"move_off": {"tasks": [{"task": "w001-t0", "distance": 1}, {"task": "t9"}]}}"#,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("move_off.tasks[1]") && e.contains("t9"), "{e}");
        let e = move_off(r#"{"move_off": {"tasks": [{"task": "w001-t0", "distance": -1}]}}"#)
            .unwrap_err()
            .to_string();
        assert!(e.contains("non-negative"), "{e}");
    }

    #[test]
    fn a_reference_of_another_schema_is_refused_clearly() {
        assert!(matches!(
            compare(&[], "[1, 2]"),
            Err(ReferenceError::NoDatasheets)
        ));
        assert!(matches!(compare(&[], "{"), Err(ReferenceError::Json(_))));
        assert!(matches!(
            compare(&[], r#"{"datasheets": [{"dt": 0.005}]}"#),
            Err(ReferenceError::NoSurface(0))
        ));
    }
}
