//! The single-wheel rig (`sim_core::soil::rig`) against terramechanics theory for the HMMWV wheel (r 0.467 m,
//! b 0.254 m) at a HMMWV wheel load (2493.6 kg x 9.81 / 4 = 6115 N) on Chrono's three SCM presets (snow, mud,
//! sand), with the presets' parameters untouched.
//!
//! References (physics.md section 4b):
//! - towed wheel: Bekker's closed forms (Wong, Theory of Ground Vehicles, 4th ed., section 2.6, rigid wheel on
//!   deformable terrain, eqs. 2.67 and 2.70): `z0 = [3 W / ((3 - n)(k_c + b k_phi) sqrt(D))]^(2/(2n+1))`,
//!   `R_c = b (k_c / b + k_phi) z0^(n+1) / (n + 1)`;
//! - driven wheel: Wong and Reece (1967) normal and shear stress around the contact arc, `theta_m = (c1 + c2 i)
//!   theta1` with c1 = 0.4, c2 = 0.3, integrated numerically here (midpoint rule, 4000 intervals), `theta1` solved
//!   from the vertical equilibrium by bisection at each slip, then the drawbar pull.
//!
//! What the SCM can and cannot reproduce. The SCM (ours as Chrono's) gives a node the Bekker pressure of its own
//! vertical sinkage while it is loaded and lets it unload elastically behind the bottom of the wheel, so the normal
//! stress is Wong-Reece's front-region law on the whole loaded arc with its maximum at the bottom: `theta_m = 0`.
//! The published `c1 = 0.4, c2 = 0.3` move the maximum forward and put pressure on the rear arc, which costs sinkage
//! (and, through `theta_m`'s slip term, slip sinkage); the SCM has neither, so against those coefficients it
//! overpredicts the pull by about 0.1 W on mud and sand and by 0.2 to 0.3 W on snow (measured: mud DP/W 0.31 vs 0.16
//! at 45% slip; snow +0.03 vs -0.20), a difference of model, not of parameters or resolution. The pull is therefore
//! checked against the Wong-Reece integral with the SCM's own pressure distribution (`c1 = c2 = 0`, same Bekker
//! law, same Janosi shear with Wong's shear displacement `j(theta)`), and the published coefficients are printed
//! beside it (`print_the_rig_table`).
//!
//! Tolerances: sinkage and motion resistance within 20% of the closed forms; drawbar pull within 20% of the
//! integral or 0.05 W, whichever is larger. The floor: on snow the pull (~0.07 W) is the difference of a traction of
//! ~0.58 W and a compaction resistance of ~0.51 W, so a relative tolerance on the difference would ask for ~2% on
//! each term; 0.05 W is 10% of each. 4 ms against 1 ms: within 5% of the value or 0.01 W.
//!
//! Grid error (measured; the table is printed by `print_the_rig_table`, run in release with `--ignored
//! --nocapture`): at the benchmark's 0.1 m grid the towed wheel's motion resistance is +18% (snow), -1% (mud), +16%
//! (sand) off Bekker, its sinkage -6%, -3%, +11%; at 0.025 m +5%, -11%, -7% and -12%, -8%, -4% (snow's closed form
//! is itself stretched: z0 = 0.36 m is 0.39 D, far from small sinkage). The pull at 0.1 m is within 14% (sand), 6%
//! (mud) and 0.043 W (snow) of the `theta_m = 0` integral, at 0.025 m within 18%, 8% and 0.013 W. The sides of the
//! wheel are resolved exactly at any grid (edge nodes weighted by the part of their cell inside the width: without
//! that a 0.254 m wheel on a 0.1 m grid covers 2 or 3 columns, a width error of -21% or +18% depending on where it
//! runs); what remains at 0.1 m is the sampling of the contact arc along the track (sand's front arc is 0.13 m
//! long, about one node).

use rayon::prelude::*;
use sim_core::soil::rig::{bekker_static_sinkage, predicted_grade_deg, Drive, RigResult, WheelRig};
use sim_core::world::SoilParams;

const R: f64 = 0.467;
const B: f64 = 0.254;
const W: f64 = 2493.6 * 9.81 / 4.0;
const SLIPS: [f64; 6] = [0.05, 0.1, 0.2, 0.3, 0.45, 0.6];
const SOILS: [(&str, SoilParams); 3] = [
    ("snow", SoilParams::SNOW),
    ("mud", SoilParams::MUD),
    ("sand", SoilParams::SAND),
];

/// Bekker's towed rigid wheel: (z0, R_c).
fn bekker_towed(s: SoilParams) -> (f64, f64) {
    let n = s.n;
    let z0 = (3.0 * W / ((3.0 - n) * (s.k_c + B * s.k_phi) * (2.0 * R).sqrt()))
        .powf(2.0 / (2.0 * n + 1.0));
    let rc = B * (s.k_c / B + s.k_phi) * z0.powf(n + 1.0) / (n + 1.0);
    (z0, rc)
}

/// Wong-Reece: (vertical load, drawbar pull) at entry angle `t1` and slip `i`, with `theta_m = (c1 + c2 i) theta1`.
fn wong_reece_forces(s: SoilParams, t1: f64, i: f64, (c1, c2): (f64, f64)) -> (f64, f64) {
    let k = (s.k_c / B + s.k_phi) * R.powf(s.n);
    let tm = (c1 + c2 * i) * t1;
    let tan_phi = s.friction_angle_deg.to_radians().tan();
    let m = 4000;
    let h = t1 / m as f64;
    let (mut wz, mut dp) = (0.0, 0.0);
    for q in 0..m {
        let t = (q as f64 + 0.5) * h;
        let te = if t >= tm || tm <= 0.0 {
            t
        } else {
            t1 - (t / tm) * (t1 - tm)
        };
        let sigma = k * (te.cos() - t1.cos()).max(0.0).powf(s.n);
        let j = R * ((t1 - t) - (1.0 - i) * (t1.sin() - t.sin()));
        let tau = (s.cohesion + sigma * tan_phi) * (1.0 - (-j / s.janosi_k).exp());
        wz += (sigma * t.cos() + tau * t.sin()) * h;
        dp += (tau * t.cos() - sigma * t.sin()) * h;
    }
    (R * B * wz, R * B * dp)
}

/// Wong-Reece drawbar pull and sinkage at slip `i` with the peak-stress coefficients `c` = (c1, c2) (theta1 from W
/// by bisection).
fn wong_reece(s: SoilParams, i: f64, c: (f64, f64)) -> (f64, f64) {
    let (mut lo, mut hi) = (1e-4, 1.5);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if wong_reece_forces(s, mid, i, c).0 < W {
            lo = mid
        } else {
            hi = mid
        }
    }
    let t1 = 0.5 * (lo + hi);
    (wong_reece_forces(s, t1, i, c).1, R * (1.0 - t1.cos()))
}

fn rig(s: SoilParams, dt: f64, delta: f64) -> WheelRig {
    let mut r = WheelRig::new(s, R, B, W);
    r.dt = dt;
    r.spacing = delta;
    r
}

fn within(sim: f64, theory: f64, rel: f64, abs: f64) -> bool {
    (sim - theory).abs() <= (rel * theory.abs()).max(abs)
}

/// Runs the towed wheel and the six slips at one grid and step.
fn runs(s: SoilParams, dt: f64, delta: f64) -> (RigResult, Vec<RigResult>) {
    let towed = rig(s, dt, delta).run(Drive::Towed);
    let driven = SLIPS
        .par_iter()
        .map(|&i| rig(s, dt, delta).run(Drive::Slip(i)))
        .collect();
    (towed, driven)
}

/// Checks one soil at the 0.1 m and 0.05 m grids, each at dt 4 ms and 1 ms.
fn check_soil(name: &str, s: SoilParams) {
    let (z0, rc) = bekker_towed(s);
    let theory: Vec<f64> = SLIPS
        .iter()
        .map(|&i| wong_reece(s, i, (0.0, 0.0)).0)
        .collect();
    let mut failures = Vec::new();
    for delta in [0.1, 0.05] {
        let (t4, d4) = runs(s, 4e-3, delta);
        let (t1, d1) = runs(s, 1e-3, delta);
        for (dt, t, d) in [(4e-3, &t4, &d4), (1e-3, &t1, &d1)] {
            let tag = format!("{name} grid {delta} dt {dt}");
            if !within(t.sinkage, z0, 0.2, 0.0) {
                failures.push(format!(
                    "{tag}: towed sinkage {:.4} vs Bekker {z0:.4}",
                    t.sinkage
                ));
            }
            if !within(-t.drawbar_pull, rc, 0.2, 0.0) {
                failures.push(format!(
                    "{tag}: motion resistance {:.0} vs Bekker {rc:.0}",
                    -t.drawbar_pull
                ));
            }
            for ((i, r), dp) in SLIPS.iter().zip(d).zip(&theory) {
                if !within(r.drawbar_pull, *dp, 0.2, 0.05 * W) {
                    failures.push(format!(
                        "{tag} slip {i}: pull {:.0} vs Wong-Reece {dp:.0}",
                        r.drawbar_pull
                    ));
                }
            }
        }
        let tag = format!("{name} grid {delta} 4 ms vs 1 ms");
        let mut pairs = vec![
            (t4.sinkage, t1.sinkage, 0.0),
            (t4.drawbar_pull, t1.drawbar_pull, 0.01 * W),
        ];
        for (a, b) in d4.iter().zip(&d1) {
            pairs.push((a.sinkage, b.sinkage, 0.0));
            pairs.push((a.drawbar_pull, b.drawbar_pull, 0.01 * W));
        }
        for (a, b, abs) in pairs {
            if !within(a, b, 0.05, abs) {
                failures.push(format!("{tag}: {a:.4} vs {b:.4}"));
            }
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

#[test]
fn snow_wheel_matches_bekker_and_wong_reece() {
    check_soil("snow", SoilParams::SNOW);
}

#[test]
fn mud_wheel_matches_bekker_and_wong_reece() {
    check_soil("mud", SoilParams::MUD);
}

#[test]
fn sand_wheel_matches_bekker_and_wong_reece() {
    check_soil("sand", SoilParams::SAND);
}

#[test]
fn predicted_grades_rise_from_snow_to_mud_to_sand() {
    let grades: Vec<f64> = SOILS
        .par_iter()
        .map(|(_, s)| predicted_grade_deg(*s, R, B, W, 4e-3, 0.1, 1))
        .collect();
    for ((name, _), g) in SOILS.iter().zip(&grades) {
        eprintln!("{name}: predicted steepest grade {g:.1} deg (HMMWV wheel, 0.1 m grid, dt 4 ms)");
    }
    assert!(grades[0] < grades[1] && grades[1] < grades[2], "{grades:?}");
    // Below the friction angle (the Mohr-Coulomb bound on a shear-only contact): compaction costs pull.
    for ((_, s), g) in SOILS.iter().zip(&grades) {
        assert!(*g < s.friction_angle_deg, "{grades:?}");
    }
}

/// The wheel pressed statically (no travel, no spin) sinks to the plate-sinkage equilibrium under its load:
/// `p = (k_c / b + k_phi) z^n` integrated over the contact chord (Bekker; Wong, Theory of Ground Vehicles, the
/// static rigid wheel), with no shear, since the soil column under a sinking rim moves with it. Benchmark grid
/// (0.1 m) and step (4 ms), three positions along the track a quarter node apart (sand's chord, 0.2 m, spans two
/// or three nodes, so where the wheel stands on the grid moves its sinkage by up to 8%); tolerance 10% (issue 13).
#[test]
fn a_wheel_pressed_statically_sinks_as_bekker_s_static_wheel() {
    for (name, s) in SOILS {
        let want = bekker_static_sinkage(s, R, B, W);
        for offset in [0.0, 0.025, 0.05] {
            let got = rig(s, 4e-3, 0.1).static_sinkage(offset);
            eprintln!(
                "{name} at {offset} m: {got:.4} m, Bekker {want:.4} m ({:+.1}%)",
                (got / want - 1.0) * 100.0
            );
            assert!(
                within(got, want, 0.10, 0.0),
                "{name} at {offset} m: {got} vs {want}"
            );
        }
    }
}

/// The wheel's sinkage does not depend on where it runs across the grid (the side nodes are weighted by the part of
/// their cell inside the width): two lateral positions half a node apart, 0.1 m grid, within 3%.
#[test]
fn the_result_does_not_depend_on_the_lateral_position_on_the_grid() {
    let mut a = rig(SoilParams::MUD, 4e-3, 0.1);
    a.distance = 2.0;
    let mut b = a;
    b.lateral = a.lateral + 0.05;
    let (ra, rb) = (a.run(Drive::Towed), b.run(Drive::Towed));
    assert!(
        within(ra.sinkage, rb.sinkage, 0.03, 0.0),
        "{ra:?} vs {rb:?}"
    );
}

#[test]
#[ignore = "prints the full table (about 10 s in release): cargo test --release --test soil_wheel_theory -- --ignored --nocapture"]
fn print_the_rig_table() {
    // (drawbar pull, sinkage) pairs as DP / W to 3 decimals and sinkage to 0.1 mm.
    let rounded = |xs: &[(f64, f64)]| -> (Vec<f64>, Vec<f64>) {
        xs.iter()
            .map(|x| ((x.0 / W * 1e3).round() / 1e3, (x.1 * 1e4).round() / 1e4))
            .unzip()
    };
    for (name, s) in SOILS {
        let (z0, rc) = bekker_towed(s);
        eprintln!(
            "{name}: Bekker towed z0 {:.4} m, R_c {:.0} N ({:.3} W)",
            z0,
            rc,
            rc / W
        );
        for (label, c) in [("", (0.4, 0.3)), (" with theta_m = 0", (0.0, 0.0))] {
            let wr: Vec<_> = SLIPS.iter().map(|&i| wong_reece(s, i, c)).collect();
            let (dp, zs) = rounded(&wr);
            eprintln!("{name}: Wong-Reece{label} DP/W at slips {SLIPS:?}: {dp:?} (sinkage {zs:?})");
        }
        for delta in [0.1, 0.05, 0.025] {
            for dt in [4e-3, 1e-3] {
                let (t, driven) = runs(s, dt, delta);
                let pairs: Vec<_> = driven.iter().map(|x| (x.drawbar_pull, x.sinkage)).collect();
                let (dp, zs) = rounded(&pairs);
                eprintln!(
                    "{name} grid {delta} dt {dt}: towed sinkage {:.4} m, R {:.0} N ({:.3} W), Fz/W {:.3}, slip {:.3}; DP/W {dp:?} sinkage {zs:?}",
                    t.sinkage,
                    -t.drawbar_pull,
                    -t.drawbar_pull / W,
                    t.vertical_force / W,
                    t.slip
                );
            }
        }
    }
}
