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
            return;
        }
        let Some(soil) = self.soil_at(p.x, p.y) else {
            return;
        };
        let k_e = soil.elastic_k.max(soil.k_phi);
        let step = self.step;
        let cell = hit.weight * self.delta * self.delta;
        let Some(node) = self.node_mut(i, j) else {
            return;
        };
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
        if s - node.plastic <= 0.0 {
            return;
        }
        node.last_step = step;
        // 2. Pressure: elastic trial, Bekker on yield.
        let (mut sigma, tangent) = node.load(&soil, k_e, s, b);
        // 3. Damping while the surface moves into the soil.
        let n = hit.normal;
        let vn = hit.v.dot(&n);
        let nz = n.z.max(MIN_NZ);
        if vn < 0.0 {
            sigma -= soil.damping * vn;
            out.normal_damping += cell * soil.damping * nz;
        }
        out.normal_stiffness += cell * tangent;
        out.unloading_stiffness += cell * k_e;
        // 4. Shear: elastic-plastic in the tangent plane. The slip `d` of the body over the soil moves the mobilised
        // shear `rho` elastically at Janosi's initial stiffness `1 / K`; where that would leave the yield circle
        // `|rho| <= 1 - exp(-h / K)` the excess hardens `h` (Janosi loading), so monotonic slip of `j` gives exactly
        // `|rho| = 1 - exp(-j / K)`, and unloading, reversal and reloading up to the previous yield are elastic.
        let k = soil.janosi_k;
        let slip = hit.v - hit.compaction_velocity;
        let trial = node.shear - n * node.shear.dot(&n) + (slip - n * slip.dot(&n)) * (dt / k);
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
        // 6. Force over the cell's area of body surface.
        let area = cell / nz;
        let f = (n * sigma - rho * tau_max) * area;
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
        out.traction_stiffness += area * dt * (k_par * c2 + k_perp * (1.0 - c2));
    }
}
