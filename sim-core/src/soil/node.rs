//! The per-node SCM law: Bekker pressure with elastic unloading, damping, and elastic-plastic Janosi-Hanamoto shear in
//! the tangent plane (steps 2 to 6 of the module's algorithm).

use super::{SoilContact, SoilGrid};
use crate::world::SoilParams;
use nalgebra::Vector3;

/// Memory of one grid node.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct Node {
    /// Plastic sinkage `s_p` below the undeformed surface, m.
    pub(super) plastic: f64,
    /// Largest pressure the node has carried, Pa.
    pub(super) yield_pressure: f64,
    /// Mobilised shear `tau / tau_max` as a vector (world frame, in the terrain's plane), `|.| <= 1`.
    pub(super) shear: Vector3<f64>,
    /// Chrono's shear displacement `j`: the slip length accumulated over every contact the node had, m (only
    /// grows).
    pub(super) hardening: f64,
    /// Step of the last contact.
    pub(super) last_step: u64,
    /// Plastic sinkage when the current contact began: the surface the body found there, m.
    pub(super) found: f64,
}

impl Node {
    /// Step 2 of the node law for a body surface `s` below the undeformed surface: the elastic trial
    /// `K_e (s - s_p)`; past the node's yield pressure, Bekker's `(k_c / b + k_phi) s^n` where it is lower, the yield
    /// pressure rises to it and the plastic sinkage follows. Returns the pressure and `d(sigma)/d(s)` on the branch
    /// taken.
    fn load(&mut self, soil: &SoilParams, k_e: f64, s: f64, b: f64) -> (f64, f64) {
        let mut sigma = k_e * (s - self.plastic);
        let mut tangent = k_e;
        if sigma > self.yield_pressure {
            let bekker = (soil.k_c / b + soil.k_phi) * s.powf(soil.n);
            if bekker < sigma {
                sigma = bekker;
                tangent = soil.n * bekker / s;
            }
            self.yield_pressure = sigma;
            self.plastic = s - sigma / k_e;
        }
        (sigma, tangent)
    }
}

/// Where a body meets the vertical ray of a node.
pub(super) struct Hit {
    /// Point of the body's surface above the node (world).
    pub(super) p: Vector3<f64>,
    /// Material velocity of the body at that point (world; a wheel's spin included).
    pub(super) v: Vector3<f64>,
    /// Unit normal of the undeformed terrain at the node (Chrono's `GetInitNormal`): the pressure acts along it and
    /// the shear in its plane.
    pub(super) normal: Vector3<f64>,
    /// Height of the undeformed terrain under `p` (Chrono's `GetInitHeight`), m.
    pub(super) ground: f64,
    /// Direction of rolling or sliding (wheel: its heading; plate: `forward`); the traction Jacobians are taken
    /// along its part in the terrain's plane.
    pub(super) heading: Vector3<f64>,
    /// Speed at which the body's surface above the node moves down into it, along `normal` (m/s; negative while it
    /// moves up): the geometric rate of the node's sinkage, `-dp_z/dt N_z` with `p` the body's surface point over
    /// the fixed node (a rolling rim's advance included). It picks the pressure branch the node moves along and
    /// when, within a step, a contact began.
    pub(super) approach: f64,
    /// A wheel's unit axle (its spin axis), zero for a plate: the spin Jacobians' lever arms.
    pub(super) axle: Vector3<f64>,
    /// The shear bristle's length over Janosi's `K` for this body ([`bristle_over_janosi`]).
    pub(super) bristle: f64,
    /// Fraction of the node's cell covered by the body (edge nodes of a wheel or plate), in (0, 1].
    pub(super) weight: f64,
    /// Height of the body's lowest point where it passed over the node during the step, if it did (a wheel's rim
    /// bottom): the node is first yielded as deep as that ([`SoilGrid::wheel_contact`]'s swept contact).
    pub(super) swept_bottom: Option<f64>,
    /// A wheel's rim over the node (`None` for a plate): where the contact's edge lies in the node's cell.
    pub(super) rim: Option<RimPoint>,
}

/// Where a node lies under a wheel's rim, along the wheel's track (a wheel with a horizontal axle).
#[derive(Clone, Copy, Debug)]
pub(super) struct RimPoint {
    /// Signed distance of the node from the wheel's centre along `forward`, `u`, m.
    pub(super) offset: f64,
    /// Height of the wheel's centre above the rim point over the node, `sqrt(r^2 - u^2)`, m.
    pub(super) height: f64,
    pub(super) radius: f64,
    /// Unit horizontal heading of the wheel.
    pub(super) forward: Vector3<f64>,
    /// The node's offset from the wheel's mid-plane along the axle (world vector).
    pub(super) lateral: Vector3<f64>,
    /// Velocity of the wheel's centre and its angular velocity (world).
    pub(super) centre_velocity: Vector3<f64>,
    pub(super) angular_velocity: Vector3<f64>,
}

/// The damping pressure's share of a node's cell (step 3).
pub(super) struct Damping {
    /// Mean damping pressure over the cell (covered fraction times the pressure), Pa; it acts along the terrain's
    /// normal.
    pub(super) pressure: f64,
    /// `-d(F_z)/d(v_z)` per unit of the cell's horizontal area, N s/m^3.
    pub(super) jacobian: f64,
    /// `-d(torque about the axle)/d(spin)` per unit of the cell's horizontal area, N m s/m^2.
    pub(super) spin_jacobian: f64,
    /// `d(pressure)/d(spin)`, Pa s: a faster spin presses the leading arc harder.
    pub(super) spin_lift: f64,
    /// Where it acts: the rim point at the damped part's midpoint, relative to the wheel's centre (world).
    pub(super) arm: Vector3<f64>,
    /// The rim's material velocity there (world; spin included).
    pub(super) velocity: Vector3<f64>,
    /// Length of the damped part along the track, m.
    pub(super) length: f64,
}

impl RimPoint {
    /// The rim's point at offset `u` along the track (relative to the wheel's centre) and its material velocity
    /// (spin included; Chrono's `v . N` is its component along the terrain normal).
    fn material(&self, u: f64) -> (Vector3<f64>, Vector3<f64>) {
        let r = self.radius;
        let arm = self.forward * u - Vector3::z() * (r * r - u * u).max(0.0).sqrt() + self.lateral;
        (
            arm,
            self.centre_velocity + self.angular_velocity.cross(&arm),
        )
    }

    /// Chrono's damping pressure `-R (v . N)` of the rim moving into the soil (`v` its material velocity, spin
    /// included; `N` the terrain normal `n`), over the part of the node's cell, along the track, that lies inside the
    /// rim's contact with the surface it found there (`found_pen`: the rim's depth below that surface at the node,
    /// negative above it; the surface is taken as level across the cell). The contact reaches
    /// `u_e = sqrt(r^2 - d^2)` from the centre, `d = height - found_pen` the centre's height above that surface; the
    /// covered part is `[u - delta / 2, u + delta / 2]` within `[-u_e, u_e]` and where the rim moves into the soil
    /// (`v . N < 0`, affine in `u` on level ground), and the pressure is taken at its midpoint. So as the rim's
    /// edge advances over a cell the damped area grows continuously, instead of a node's whole cell switching on
    /// when its ray is first pressed.
    pub(super) fn damping(
        &self,
        found_pen: f64,
        delta: f64,
        n: &Vector3<f64>,
        axle: &Vector3<f64>,
        r_damping: f64,
    ) -> Option<Damping> {
        let r = self.radius;
        let d = self.height - found_pen;
        if d >= r {
            return None;
        }
        let reach = if d <= 0.0 { r } else { (r * r - d * d).sqrt() };
        let (mut lo, mut hi) = (
            (self.offset - 0.5 * delta).max(-reach),
            (self.offset + 0.5 * delta).min(reach),
        );
        if hi <= lo {
            return None;
        }
        let (vn_lo, vn_hi) = (self.material(lo).1.dot(n), self.material(hi).1.dot(n));
        if vn_lo >= 0.0 && vn_hi >= 0.0 {
            return None;
        }
        if (vn_lo < 0.0) != (vn_hi < 0.0) {
            // Only the part moving into the soil: cut where `v . N` changes sign.
            let cut = lo + (hi - lo) * vn_lo / (vn_lo - vn_hi);
            if vn_lo < 0.0 {
                hi = cut;
            } else {
                lo = cut;
            }
        }
        if hi <= lo {
            return None;
        }
        let covered = (hi - lo) / delta;
        let (arm, velocity) = self.material(0.5 * (lo + hi));
        let vn = velocity.dot(n);
        if vn >= 0.0 {
            return None;
        }
        let lever = axle.dot(&arm.cross(n));
        Some(Damping {
            pressure: -r_damping * vn * covered,
            jacobian: r_damping * n.z * n.z * covered,
            spin_jacobian: r_damping * covered * lever * lever,
            spin_lift: -r_damping * covered * lever,
            arm,
            velocity,
            length: hi - lo,
        })
    }
}

/// The shear's elastic (bristle) length over Janosi's `K` on a rolling wheel, and at rest: the slip a node's
/// mobilised shear takes to follow a change of the slip's direction. Chrono's SCM has none (its shear flips the step
/// the slip velocity does), which would chatter at rest. On a rolling wheel the slip reverses on the leading arc, and
/// the bristle's lag there costs drawbar pull against Chrono's instant flip, growing as the bristle's square root:
/// `K / 200` (0.05 mm on snow and mud) costs about 0.01 W at 20% slip (`tests/soil_chrono_reference.rs`), `K / 20`
/// 0.06 W. At rest the bristle is `K / 20`, soft enough that a parked vehicle's chassis does not rattle on it (with
/// `K / 200` a braked HMMWV on snow digs 3.7 mm deeper in 30 s, with `K / 20` 0.8 mm). A wheel's bristle blends
/// between the two over the creep speed ([`bristle_over_janosi`]). A plate's slip does not reverse across its
/// contact, so it keeps the rest value (a bristle whose length changes while it is loaded ratchets: a plate
/// swinging under a steady load at creep speeds crept 5 mm in 30 s).
const BRISTLE_MOVING: f64 = 0.005;
pub(super) const BRISTLE_AT_REST: f64 = 0.05;

/// The bristle's length over Janosi's `K` for a body whose surface moves at `speed` over the soil (a wheel: the
/// larger of its centre's and its rim's speed), with the creep speed `creep`: `K / 20` at rest, `K / 200` above
/// creep speeds, `exp(-(v / v_creep)^2)` between (the velocity-dependent bristle of Olsson et al., Friction models
/// and friction compensation, Eur. J. Control 4, 1998, as the vehicle's creep damping).
pub(super) fn bristle_over_janosi(speed: f64, creep: f64) -> f64 {
    let rest = (-(speed / creep).powi(2)).exp();
    BRISTLE_MOVING + (BRISTLE_AT_REST - BRISTLE_MOVING) * rest
}

impl SoilGrid {
    /// SCM update of node `(i, j)` pressed by a body surface at `hit`; `b` is the Bekker contact width. Adds the
    /// node's force to `out` (torque about `centre`) together with its share of the Jacobians.
    ///
    /// One piece on purpose: its numbered steps are Chrono's per-node SCM update in Chrono's order
    /// (`scm-chrono-formulation.md`), each reading what the step before left in the node it holds borrowed; split,
    /// every part would take the node, the hit, the soil and a dozen of the steps' values, and the order that
    /// makes the model Chrono's would no longer read top to bottom.
    pub(super) fn press_node(
        &mut self,
        (i, j): (usize, usize),
        hit: &Hit,
        b: f64,
        centre: &Vector3<f64>,
        dt: f64,
        out: &mut SoilContact,
    ) {
        let p = hit.p;
        let n = hit.normal;
        let h0 = hit.ground;
        // Chrono's sinkage: the node's depth under its initial level times `N_z` (`p_hit_offset`).
        let s = n.z * (h0 - p.z);
        let swept = hit
            .swept_bottom
            .map(|z| n.z * (h0 - z))
            .filter(|s| *s > 0.0);
        if s <= 0.0 && swept.is_none() {
            if hit.rim.is_some() {
                let pen = s - self.plastic_at(i, j);
                self.edge_damping(hit, pen, out);
            }
            return;
        }
        let Some(soil) = self.soil_at(p.x, p.y) else {
            return;
        };
        let k_e = soil.elastic_k.max(soil.k_phi);
        let step = self.step;
        let delta = self.delta;
        let cell = hit.weight * self.delta * self.delta;
        let Some(node) = self.node_mut(i, j) else {
            return;
        };
        // The surface the body found at this node: where it stood before the node's current contact began.
        let entering = node.last_step + 1 < step;
        let found = if entering { node.plastic } else { node.found };
        if let Some(s_swept) = swept {
            node.load(&soil, k_e, s_swept, b);
        }
        if s <= 0.0 {
            return;
        }
        if entering || s - node.plastic <= 0.0 {
            // A new contact starts with no elastic shear; the shear displacement `j` (hardening) is kept.
            node.shear = Vector3::zeros();
        }
        let pen = s - node.plastic;
        if pen <= 0.0 {
            self.edge_damping(hit, pen, out);
            return;
        }
        node.last_step = step;
        node.found = found;
        // 2. Pressure: elastic trial, Bekker on yield.
        let (sigma, tangent) = node.load(&soil, k_e, s, b);
        // 3. Damping while the body's material moves into the soil: a wheel's over the part of the cell its rim
        // covers ([`RimPoint::damping`], its edge found from the surface the rim found here, which the soil ahead
        // still has); a plate's over the whole cell.
        let vn = hit.v.dot(&n);
        let arm = p - centre;
        let (damping, damping_arm) = match hit.rim {
            Some(rim) => rim
                .damping(s - found, delta, &n, &hit.axle, soil.damping)
                .map_or((0.0, arm), |d| {
                    out.normal_damping += cell * d.jacobian;
                    out.spin_stiffness += cell * d.spin_jacobian;
                    out.spin_lift += cell * d.spin_lift;
                    (d.pressure, d.arm)
                }),
            None if vn < 0.0 => {
                out.normal_damping += cell * soil.damping * n.z * n.z;
                (-soil.damping * vn, arm)
            }
            None => (0.0, arm),
        };
        let sigma_total = sigma + damping;
        // The branch the node moves along: a node the body's surface moves into stays on the branch it is on; one
        // it moves away from (or rests on) unloads along the elastic line.
        let approach = hit.approach;
        out.normal_stiffness += cell * n.z * n.z * if approach > 0.0 { tangent } else { k_e };
        // 4. Shear in the terrain's plane, opposite the slip (the material velocity's tangential part, spin
        // included). Chrono's shear displacement `j` grows by the slip's length every step the node is in contact
        // and is never reset, so a rear wheel in the front wheel's rut finds it mobilised; `tau = tau_max (1 -
        // exp(-j / K))`. Its direction follows the slip through an elastic bristle of length `l`
        // ([`bristle_over_janosi`]): the mobilised shear `rho` moves by `d / l` and stays within `|rho| <= 1 -
        // exp(-j / K)`. The slip accrues from when the body reached the node: in the step the contact begins, for
        // the part of the step since the body's surface passed the surface it found, `(s - found) / approach`; so
        // the first step does not add a whole step's slip (at 4 ms and 5 m/s of slip that is 2 Janosi lengths of
        // snow).
        let k = soil.janosi_k;
        let ell = k * hit.bristle;
        let slip = hit.v - n * vn;
        let t_slip = if entering && approach > 0.0 && approach * dt > s - found {
            ((s - found) / approach).max(0.0)
        } else {
            dt
        };
        // The step's shear acts at the displacement it reaches half-way through the step (midpoint rule): at speed
        // a node stays under a wheel for only a few steps, and the end-of-step value overstates the mobilised shear.
        let step_slip = slip.norm() * t_slip;
        let j_mid = node.hardening + 0.5 * step_slip;
        node.hardening += step_slip;
        let trial = node.shear - n * node.shear.dot(&n) + slip * (t_slip / ell);
        let tn = trial.norm();
        let decay = (-j_mid / k).exp();
        let yield_ratio = 1.0 - decay;
        let plastic = tn > yield_ratio;
        let rho = if plastic {
            trial * (yield_ratio / tn)
        } else {
            trial
        };
        node.shear = rho;
        // 5. Janosi-Hanamoto shear opposing the slip: `tau = tau_max rho`, with the damping in `sigma` (Chrono).
        let tau_max =
            (soil.cohesion + sigma_total * soil.friction_angle_deg.to_radians().tan()).max(0.0);
        // 6. Force over the cell's horizontal area (Chrono's `delta^2`): pressure along the terrain normal, shear in
        // its plane.
        let f = (n * sigma - rho * tau_max) * cell;
        let f_damping = n * (damping * cell);
        out.force += f + f_damping;
        // The damping acts where it was taken, at the damped part's midpoint (on a fast wheel's leading edge up to
        // half a cell from the node): its moment about the axle is the spin's largest resistance at speed.
        out.torque += arm.cross(&f) + damping_arm.cross(&f_damping);
        out.normal += sigma_total * cell;
        out.shear_capacity += tau_max * cell;
        out.sinkage = out.sinkage.max(s);
        out.nodes += 1;
        // Jacobians of the shear along the rolling direction with respect to the slip velocity: elastic `tau_max /
        // l`; on yield along the mobilised shear Janosi's slope `tau_max exp(-j / K) / K`, across it
        // `tau_max |rho| / (l |rho_trial|)`; each times the slip time.
        let k0 = tau_max / ell;
        let (k_par, k_perp) = if plastic {
            (tau_max * decay / k, k0 * yield_ratio / tn)
        } else {
            (k0, k0)
        };
        shear_jacobians(hit, &arm, &rho, (k_par, k_perp), cell * t_slip, out);
    }

    /// A node the rim does not press yet (`pen <= 0`, the rim above its surface) whose cell the rim's advancing
    /// edge already reaches into: the damping pressure over the covered part of the cell ([`RimPoint::damping`])
    /// and the shear it carries, and nothing else (no sinkage, no memory). At speed the damping pressure lifts a
    /// wheel out of soft soil, and whole cells switching on one per `delta` of travel made the wheels hop at a rate
    /// set by the grid and the step.
    fn edge_damping(&self, hit: &Hit, pen: f64, out: &mut SoilContact) {
        let Some(rim) = hit.rim else {
            return;
        };
        let Some(soil) = self.soil_at(hit.p.x, hit.p.y) else {
            return;
        };
        let n = hit.normal;
        let Some(d) = rim.damping(pen, self.delta, &n, &hit.axle, soil.damping) else {
            return;
        };
        let cell = hit.weight * self.delta * self.delta;
        // In Chrono the damping is part of the node's `sigma` and so of its shear strength (`tau_max = c + sigma
        // tan phi`, `SCMTerrain.cpp` after `sigma += -Vn R`), so the damped edge shears too: opposite the rim's
        // slip there, no cohesion (no soil is pressed yet), mobilised by the slip since the rim reached it (`j =
        // |v_t| t_c`; not stored). Without it (r7) a wheel spinning on soil rode on frictionless damping pressure
        // at its leading edge (half its load on mud at full spin) and lost half its traction: the HMMWV stalled on
        // mud at 21 degrees where Chrono's law climbs 27.
        let slip = d.velocity - n * d.velocity.dot(&n);
        let sn = slip.norm();
        let tau_max = d.pressure * soil.friction_angle_deg.to_radians().tan();
        let mut f = n * (d.pressure * cell);
        if sn > 1e-12 {
            let k = soil.janosi_k;
            // The time the damped part has been under the rim: its length over the rim's advance (a wheel that
            // spins in place keeps its edge over the same soil, fully mobilised).
            let advance = rim.centre_velocity.dot(&rim.forward).abs();
            let t_c = (d.length / advance).min(EDGE_CONTACT_TIME_CAP);
            let decay = (-sn * t_c / k).exp();
            let rho = slip * ((1.0 - decay) / sn);
            f -= rho * (tau_max * cell);
            // Slopes along the slip (Janosi's) and across it (the direction's turn), per unit slip velocity.
            let k_par = tau_max * decay * t_c / k;
            let k_perp = tau_max * (1.0 - decay) / sn;
            shear_jacobians(hit, &d.arm, &rho, (k_par, k_perp), cell, out);
        }
        out.shear_capacity += tau_max * cell;
        out.force += f;
        out.torque += d.arm.cross(&f);
        out.normal += d.pressure * cell;
        out.normal_damping += cell * d.jacobian;
        out.spin_stiffness += cell * d.spin_jacobian;
        out.spin_lift += cell * d.spin_lift;
    }
}

/// Longest time a damped edge counts as under the rim, s (a wheel spinning in place: fully mobilised long before).
const EDGE_CONTACT_TIME_CAP: f64 = 10.0;

/// Adds a node's (or damped edge cell's) shear Jacobians along the rolling direction to `out`: `k_par` the slope of
/// `|tau|` against slip velocity along the mobilised shear `rho`, `k_perp` across it, both per unit area and already
/// in force per (m/s) when `scale` (the cell's area times the slip time) multiplies them; `arm` from the wheel's
/// centre.
fn shear_jacobians(
    hit: &Hit,
    arm: &Vector3<f64>,
    rho: &Vector3<f64>,
    (k_par, k_perp): (f64, f64),
    scale: f64,
    out: &mut SoilContact,
) {
    let n = hit.normal;
    // The rolling direction in the terrain's plane.
    let roll = (hit.heading - n * hit.heading.dot(&n)).normalize();
    let rn = rho.norm();
    let c2 = if rn > 1e-12 {
        (rho.dot(&roll) / rn).powi(2)
    } else {
        1.0
    };
    let stiffness = scale * (k_par * c2 + k_perp * (1.0 - c2));
    out.traction_stiffness += stiffness;
    // The spin moves the slip along `roll` by `lever` per rad/s (`-h` under a wheel's centre).
    let lever = hit.axle.cross(arm).dot(&roll);
    out.spin_force -= stiffness * lever;
    out.spin_stiffness += stiffness * lever * lever;
}
