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
    /// Mobilised shear `tau / tau_max` as a vector (world frame, in the contact's tangent plane), `|.| <= 1`.
    pub(super) shear: Vector3<f64>,
    /// Janosi shear displacement reached so far (the shear's hardening variable), m.
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
    /// Velocity of that point (world).
    pub(super) v: Vector3<f64>,
    /// Unit surface normal of the body there, pointing out of the soil (the direction the pressure pushes the body).
    pub(super) normal: Vector3<f64>,
    /// Unit tangent along which the body rolls or slides (wheel: the rim's direction of travel; plate: `forward`);
    /// only used for [`SoilContact::traction_stiffness`].
    pub(super) roll: Vector3<f64>,
    /// Fraction of the node's cell covered by the body (edge nodes of a wheel or plate), in (0, 1].
    pub(super) weight: f64,
    /// The body's sinking motion: its centre's velocity along the undeformed ground's normal while it moves into
    /// the soil, else zero (world). The soil column under the contact moves down with a sinking body (plastic
    /// compaction), so that motion is not slip and is taken out of the shear's slip velocity; a rising body leaves
    /// the soil behind (it rebounds only elastically, millimetres) and slides along it.
    pub(super) compaction_velocity: Vector3<f64>,
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
    /// Velocity of the wheel's centre (the rim's spin is tangent to the rim, so `v . N` of a rim point is the
    /// centre's).
    pub(super) centre_velocity: Vector3<f64>,
}

/// The damping pressure's share of a node's cell (step 3).
pub(super) struct Damping {
    /// Force per unit of the cell's horizontal area, N/m^2.
    pub(super) force: Vector3<f64>,
    /// Mean damping pressure over the cell (covered fraction times the pressure), Pa.
    pub(super) pressure: f64,
    /// `-d(F_z)/d(v_z)` per unit of the cell's horizontal area, N s/m^3.
    pub(super) jacobian: f64,
}

impl RimPoint {
    /// The damping pressure `R |v . N|` of the rim moving into the soil over the part of the node's cell, along the
    /// track, that lies inside the rim's contact with the surface the rim found there (`found_pen`: the rim's depth
    /// below that surface at the node, negative above it; the surface is taken as level across the cell). The
    /// contact reaches `u_e = sqrt(r^2 - d^2)` from the centre, `d = height - found_pen` the centre's height above
    /// that surface; the covered part is `[u - delta / 2, u + delta / 2]` within `[-u_e, u_e]` and on the side
    /// where the rim moves into the soil, and the pressure, normal and surface area are taken at its midpoint. So as
    /// the rim's edge advances over a cell the damped area grows continuously, instead of a node's whole cell
    /// switching on when its ray is first pressed.
    pub(super) fn damping(&self, found_pen: f64, delta: f64, r_damping: f64) -> Option<Damping> {
        self.damped_part(found_pen, delta)
            .map(|part| part.damping(r_damping))
    }

    /// The geometry of [`RimPoint::damping`]: the damped part of the cell, or `None` (cheap for the nodes the
    /// rim's contact does not reach, which are most of those under a wheel's footprint).
    pub(super) fn damped_part(&self, found_pen: f64, delta: f64) -> Option<DampedPart> {
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
        // The rim moves into the soil (`v . N < 0`) on one side of `u* = r v_z / |v|` (for `v_f > 0`, ahead of it;
        // `N = (-u f + h z) / r`, so `-v . N = |v| sin(theta - alpha)`, `alpha` the velocity's angle): only that
        // part of the cell is damped (else a cell straddling the bottom of a rolling wheel is damped whole or not
        // at all).
        let vf = self.centre_velocity.dot(&self.forward);
        let vz = self.centre_velocity.z;
        let speed = vf.hypot(vz);
        if vf > 0.0 {
            lo = lo.max(r * vz / speed);
        } else if vf < 0.0 {
            hi = hi.min(-r * vz / speed);
        } else if vz >= 0.0 {
            return None;
        }
        if hi <= lo {
            return None;
        }
        let covered = (hi - lo) / delta;
        let u = 0.5 * (lo + hi);
        let normal = (Vector3::z() * (r * r - u * u).sqrt() - self.forward * u) / r;
        let vn = self.centre_velocity.dot(&normal);
        if vn >= 0.0 {
            return None;
        }
        Some(DampedPart {
            covered,
            normal,
            vn,
        })
    }
}

/// The part of a node's cell a rim damps ([`RimPoint::damped_part`]).
pub(super) struct DampedPart {
    /// Its length along the track over the cell's, in (0, 1].
    covered: f64,
    /// The rim's unit normal at its midpoint and the centre's velocity along it (negative: into the soil).
    normal: Vector3<f64>,
    vn: f64,
}

impl DampedPart {
    /// The damping pressure `R |v . N|` over the part, for the soil's damping coefficient `r_damping`.
    pub(super) fn damping(&self, r_damping: f64) -> Damping {
        let nz = self.normal.z.max(MIN_NZ);
        let pressure = -r_damping * self.vn * self.covered;
        Damping {
            force: self.normal * (pressure / nz),
            pressure,
            jacobian: r_damping * nz * self.covered,
        }
    }
}

/// The normal's vertical component below which the surface area of a cell is no longer taken as `delta^2 / n_z`
/// (a rim point level with the centre would otherwise get an unbounded area).
const MIN_NZ: f64 = 0.1;

impl SoilGrid {
    /// SCM update of node `(i, j)` pressed by a body surface at `hit`; `b` is the Bekker contact width. Adds the
    /// node's force to `out` (torque about `centre`) together with its share of the Jacobians.
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
        let h0 = self.heights.height_bilinear(p.x, p.y);
        let s = h0 - p.z;
        let swept = hit.swept_bottom.map(|z| h0 - z).filter(|s| *s > 0.0);
        if s <= 0.0 && swept.is_none() {
            if hit.rim.is_some() {
                let pen = s - self.plastic_at(i, j);
                self.edge_damping(hit, pen, centre, out);
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
        if s - node.plastic <= 0.0 || node.last_step + 1 < step {
            node.shear = Vector3::zeros();
            node.hardening = 0.0;
        }
        let pen = s - node.plastic;
        if pen <= 0.0 {
            self.edge_damping(hit, pen, centre, out);
            return;
        }
        node.last_step = step;
        node.found = found;
        // 2. Pressure: elastic trial, Bekker on yield.
        let (mut sigma, tangent) = node.load(&soil, k_e, s, b);
        // 3. Damping while the surface moves into the soil: a wheel's over the part of the cell its rim covers
        // ([`RimPoint::damping`], its edge found from the surface the rim found here, which the soil ahead still
        // has); a plate's over the whole cell.
        let n = hit.normal;
        let nz = n.z.max(MIN_NZ);
        let (mut damping_force, mut damping_pressure) = (Vector3::zeros(), 0.0);
        match hit.rim {
            Some(rim) => {
                if let Some(d) = rim.damping(s - found, delta, soil.damping) {
                    sigma += d.pressure;
                    damping_pressure = d.pressure;
                    damping_force = d.force * cell;
                    out.normal_damping += cell * d.jacobian;
                }
            }
            None => {
                let vn = hit.v.dot(&n);
                if vn < 0.0 {
                    sigma -= soil.damping * vn;
                    out.normal_damping += cell * soil.damping * nz;
                }
            }
        }
        // The branch the node moves along: a node the body's surface moves into stays on the branch it is on; one
        // it moves away from (or rests on) unloads along the elastic line.
        let approach = -hit.v.dot(&n) / nz;
        out.normal_stiffness += cell * if approach > 0.0 { tangent } else { k_e };
        // 4. Shear: elastic-plastic in the tangent plane. The slip `d` of the body over the soil moves the mobilised
        // shear `rho` elastically at Janosi's initial stiffness `1 / K`; where that would leave the yield circle
        // `|rho| <= 1 - exp(-h / K)` the excess hardens `h` (Janosi loading), so monotonic slip of `j` gives exactly
        // `|rho| = 1 - exp(-j / K)`, and unloading, reversal and reloading up to the previous yield are elastic.
        // The slip displacement accrues from when the body reached the node: in the step the contact begins, for
        // the part of the step since the body's surface passed the surface it found, `(s - found) / approach` with
        // `approach = -(v . N) / N_z` the speed at which the body's surface above the node moves down; so the first
        // step does not add a whole step's slip (at 4 ms and 5 m/s of slip that is 2 Janosi lengths of snow).
        let k = soil.janosi_k;
        let slip = hit.v - hit.compaction_velocity;
        let t_slip = if entering && approach > 0.0 && approach * dt > s - found {
            ((s - found) / approach).max(0.0)
        } else {
            dt
        };
        let trial = node.shear - n * node.shear.dot(&n) + (slip - n * slip.dot(&n)) * (t_slip / k);
        let tn = trial.norm();
        let yield_ratio = 1.0 - (-node.hardening / k).exp();
        let plastic = tn > yield_ratio;
        let (rho, ratio) = if plastic {
            node.hardening += k * (tn - yield_ratio);
            let ratio = (-node.hardening / k).exp();
            (trial * ((1.0 - ratio) / tn), ratio)
        } else {
            (trial, 1.0)
        };
        node.shear = rho;
        // 5. Janosi-Hanamoto shear opposing the body's slip: `tau = tau_max rho`.
        let tau_max = soil.cohesion + sigma * soil.friction_angle_deg.to_radians().tan();
        let rn = rho.norm();
        // 6. Force over the cell's area of body surface (a wheel's damping along the rim's normal where it acts; a
        // plate's is in `sigma`).
        let area = cell / nz;
        let f = (n * (sigma - damping_pressure) - rho * tau_max) * area + damping_force;
        out.force += f;
        out.torque += (p - centre).cross(&f);
        out.normal += sigma * area;
        out.shear_capacity += tau_max * area;
        out.sinkage = out.sinkage.max(s);
        out.nodes += 1;
        // d|tau|/dj along the mobilised shear (elastic: tau_max / K; on yield: Janosi's slope) and across it.
        let k0 = tau_max / k;
        let k_par = k0 * ratio;
        let k_perp = if plastic { k0 * rn / tn } else { k0 };
        let c2 = if rn > 1e-12 {
            (rho.dot(&hit.roll) / rn).powi(2)
        } else {
            1.0
        };
        out.traction_stiffness += area * t_slip * (k_par * c2 + k_perp * (1.0 - c2));
    }

    /// A node the rim does not press yet (`pen <= 0`, the rim above its surface) whose cell the rim's advancing
    /// edge already reaches into: the damping pressure over the covered part of the cell ([`RimPoint::damping`]),
    /// and nothing else (no sinkage, no shear, no memory). At speed the damping pressure lifts a wheel out of soft
    /// soil (the towed rig's HMMWV wheel on snow rides 34 cm deep at 0.25 m/s, 14 cm at 5 m/s, 8 cm at 10 m/s),
    /// and whole cells switching on one per `delta` of travel made the wheels hop at a rate set by the grid and the
    /// step.
    fn edge_damping(&self, hit: &Hit, pen: f64, centre: &Vector3<f64>, out: &mut SoilContact) {
        let Some(part) = hit.rim.and_then(|rim| rim.damped_part(pen, self.delta)) else {
            return;
        };
        let Some(soil) = self.soil_at(hit.p.x, hit.p.y) else {
            return;
        };
        let d = part.damping(soil.damping);
        let cell = hit.weight * self.delta * self.delta;
        let f = d.force * cell;
        out.force += f;
        out.torque += (hit.p - centre).cross(&f);
        out.normal += f.norm();
        out.normal_damping += cell * d.jacobian;
    }
}
