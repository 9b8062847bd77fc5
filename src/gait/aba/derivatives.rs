//! Analytical first derivatives of the state derivative `f(x, u) = (q̇, v̇)` of
//! [`crate::gait::sim`] with respect to the state `x = (q, v)` and the actuator forces `u`, in
//! `f64`: the Carpentier–Mansard (2018) route, `∂v̇/∂x = M⁻¹·∂(τ − RNEA(q, v, v̇*))/∂x`,
//! `∂v̇/∂u = M⁻¹·B`, with `v̇*` the articulated-body solution held fixed (implicit function
//! theorem on `M(q)·v̇ + C(q, v) = τ(q, v, u)`).
//!
//! Tangent RNEA in link coordinates. A configuration direction `δ` on joint `i` (a column `s` of
//! its motion subspace, link coordinates) moves link `i` and its subtree rigidly by the twist `s`:
//! the parent-to-link transform changes as `δ(ⁱX_λ) = −s×·ⁱX_λ`, so, for links `j` in the
//! subtree (`X = ʲX_λ`, `v_J = S_j·q̇_j`, `X·v_λ`, `X·a_λ` the parent's velocity and
//! acceleration seen from `j`):
//! ```text
//!   j = i (position):  δv = −s × (X·v_λ)            δa = −s × (X·a_λ) + δv × v_J    ξ = s
//!   j = i (velocity):  δv = s                       δa = δv × v_J + v × s           ξ = 0
//!   j below i:         δv = X·δv_λ                  δa = X·δa_λ + δv × v_J          ξ = X·ξ_λ
//!   δf_j = I·δa + δv ×* (I·v) + v ×* (I·δv) − δf_ext      (inertia I constant in link coords)
//!   δF_λ += Xᵀ·δF_j  (+ Xᵀ·(s ×* F_j) when j = i, position)   δτ_k = S_kᵀ·δF_{link k}
//! ```
//! `ξ` is the link's pose perturbation (a twist in link coordinates), giving the contact points'
//! world displacement `Eᵀ(ξ_lin + ξ_ang × p)` and velocity change
//! `Eᵀ(δv_lin + δv_ang × p + ξ_ang × (v_lin + v_ang × p))`, chained through the contact law's
//! partials (seed eq. 3.26–3.27 and the friction of [`crate::gait::contact`]); the link-frame
//! force changes by `E·δF_w − ξ_ang × (E·F_w)`. Passive springs, dampers and limit springs
//! add `∂τ_p/∂q`, `∂τ_p/∂q̇` on their scalar joints.
//!
//! The tangent directions are per velocity coordinate; a planar base `q = (x, y, θ)` with body
//! velocities `v = (ω, v_x, v_y)` maps coordinates to tangents by
//! `δω = dθ`, `(δv_x, δv_y) = R(θ)ᵀ(dx, dy)`. Floating (quaternion) joints are not supported
//! here ([`StageLinearizer::new`] returns `None`); the dual-number path covers them.
//!
//! Units follow the state: `∂v̇/∂q` in 1/s² (per m or rad), `∂v̇/∂v` in 1/s, `∂v̇/∂u` in 1/(kg·m²)
//! or 1/kg.

// Index loops mirror the matrix subscripts.
#![allow(clippy::needless_range_loop)]

use super::Dynamics;
use crate::gait::character::{JointKind, Model};
use crate::gait::contact::{add_contact_forces, contact_force};
use crate::gait::spatial::{ArticulatedInertia, Force, Motion, RigidInertia, Vec3};

/// Contact-point data reused by every tangent direction of one evaluation.
#[derive(Debug, Clone, Copy)]
struct ContactPoint {
    link: usize,
    /// Point in link coordinates (m).
    p: Vec3<f64>,
    /// Contact force in link coordinates (N).
    f_link: Vec3<f64>,
    /// Link-frame velocity of the point, `v_lin + v_ang × p` (m/s).
    u: Vec3<f64>,
    /// `∂F_w/∂h` (N/m), h the height.
    d_height: [f64; 3],
    /// `∂F_w/∂ṗ_w` (N·s/m), rows = force components.
    d_vel: [[f64; 3]; 3],
}

/// Reusable evaluator of `f(x, u)` and its Jacobians for one model.
#[derive(Debug, Clone)]
pub struct StageLinearizer<'m> {
    model: &'m Model,
    dynamics: Dynamics<f64>,
    f_ext: Vec<Force<f64>>,
    tau: Vec<f64>,
    inertia: Vec<RigidInertia<f64>>,
    /// Joint velocity `S·q̇` per link.
    vj: Vec<Motion<f64>>,
    /// Parent velocity and acceleration in link coordinates.
    xv: Vec<Motion<f64>>,
    xa: Vec<Motion<f64>>,
    acc: Vec<Motion<f64>>,
    /// `I·v` per link.
    momentum: Vec<Force<f64>>,
    /// Subtree forces of RNEA at `v̇*`.
    subtree: Vec<Force<f64>>,
    contacts: Vec<ContactPoint>,
    /// Each link's own spatial inertia as a 6×6 block matrix (constant in link coordinates).
    body_blocks: Vec<ArticulatedInertia<f64>>,
    composite: Vec<ArticulatedInertia<f64>>,
    /// Mass matrix, then its Cholesky factor (row-major nv × nv).
    chol: Vec<f64>,
    /// Right-hand sides / solutions, column-major, `2nv + na` columns of length nv.
    cols: Vec<f64>,
    dv: Vec<Motion<f64>>,
    da: Vec<Motion<f64>>,
    xi: Vec<Motion<f64>>,
    df: Vec<Force<f64>>,
    inside: Vec<bool>,
    /// Whether a link's subtree carries contact points (its pose perturbation matters).
    touches: Vec<bool>,
    /// Each velocity coordinate's link and motion-subspace column (link coordinates).
    columns: Vec<(usize, Motion<f64>)>,
}

impl<'m> StageLinearizer<'m> {
    /// Scratch space for `model`; `None` if it has a floating (quaternion) joint.
    pub fn new(model: &'m Model) -> Option<Self> {
        if model
            .links
            .iter()
            .any(|l| matches!(l.joint, JointKind::Floating))
        {
            return None;
        }
        let n = model.links.len();
        let nv = model.nv;
        let mz = vec![Motion::zero(); n];
        let fz = vec![Force::zero(); n];
        Some(StageLinearizer {
            model,
            dynamics: Dynamics::new(model),
            f_ext: fz.clone(),
            tau: vec![0.0; nv],
            inertia: model.links.iter().map(|l| l.inertia_t::<f64>()).collect(),
            vj: mz.clone(),
            xv: mz.clone(),
            xa: mz.clone(),
            acc: mz.clone(),
            momentum: fz.clone(),
            subtree: fz.clone(),
            contacts: Vec::new(),
            body_blocks: model
                .links
                .iter()
                .map(|l| l.inertia_t::<f64>().to_articulated())
                .collect(),
            composite: vec![ArticulatedInertia::zero(); n],
            chol: vec![0.0; nv * nv],
            cols: vec![0.0; nv * (2 * nv + model.actuators.len())],
            dv: mz.clone(),
            da: mz.clone(),
            xi: mz,
            df: fz,
            inside: vec![false; n],
            touches: subtree_contacts(model),
            columns: model
                .links
                .iter()
                .enumerate()
                .flat_map(|(i, l)| (0..l.joint.nv()).map(move |k| (i, l.joint.subspace(k))))
                .collect(),
        })
    }

    /// Evaluates `q̇` (length nq) and `v̇` (length nv) at state `(q, v)` under actuator forces
    /// `act` exactly as [`crate::gait::sim::Simulator::derivative`] does, and the Jacobians
    /// `jx = ∂f/∂x` (row-major `nx × nx`, `nx = nq + nv`, `x = (q, v)`) and `ju = ∂f/∂u`
    /// (row-major `nx × na`).
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate(
        &mut self,
        q: &[f64],
        v: &[f64],
        act: &[f64],
        qd: &mut [f64],
        vd: &mut [f64],
        jx: &mut [f64],
        ju: &mut [f64],
    ) {
        let m = self.model;
        let (nq, nv, na) = (m.nq, m.nv, m.actuators.len());
        let nx = nq + nv;
        // The state derivative, as in the simulator.
        self.dynamics.kinematics(m, q, v);
        self.f_ext.fill(Force::zero());
        add_contact_forces(m, &self.dynamics, &mut self.f_ext);
        self.tau.fill(0.0);
        m.add_passive(q, v, &mut self.tau);
        for (a, f) in m.actuators.iter().zip(act) {
            self.tau[m.links[a.link].v_index] += *f;
        }
        m.qdot(q, v, qd);
        self.dynamics.accelerations(m, &self.tau, &self.f_ext, vd);

        self.rnea(v, vd);
        self.linearize_contacts();
        self.mass_matrix();
        cholesky(nv, &mut self.chol);

        // Right-hand sides: ∂(τ_p − RNEA)/∂(δ, v) and the actuator columns.
        let mut cols = std::mem::take(&mut self.cols);
        cols.fill(0.0);
        for (i, l) in m.links.iter().enumerate() {
            for k in 0..l.joint.nv() {
                let c = l.v_index + k;
                self.tangent(i, k, true, &mut cols[c * nv..(c + 1) * nv]);
                self.tangent(i, k, false, &mut cols[(nv + c) * nv..(nv + c + 1) * nv]);
            }
            if l.joint.is_scalar() {
                let (qi, c) = (q[l.q_index], l.v_index);
                if let Some(s) = l.spring {
                    cols[c * nv + c] -= s.stiffness;
                    cols[(nv + c) * nv + c] -= s.damping;
                }
                if let Some(lim) = l.limits {
                    cols[c * nv + c] += limit_stiffness(&lim, qi);
                }
            }
        }
        for (a, act) in m.actuators.iter().enumerate() {
            cols[(2 * nv + a) * nv + m.links[act.link].v_index] = 1.0;
        }
        for col in cols.chunks_mut(nv) {
            cholesky_solve(nv, &self.chol, col);
        }

        // Assemble jx = [[∂q̇/∂q, ∂q̇/∂v], [∂v̇/∂q, ∂v̇/∂v]] and ju = [0; ∂v̇/∂u].
        jx.fill(0.0);
        ju.fill(0.0);
        for r in 0..nv {
            let row = &mut jx[(nq + r) * nx..(nq + r + 1) * nx];
            for c in 0..nv {
                row[nq + c] = cols[(nv + c) * nv + r];
            }
            for a in 0..na {
                ju[(nq + r) * na + a] = cols[(2 * nv + a) * nv + r];
            }
        }
        for l in &m.links {
            let (a, b) = (l.q_index, l.v_index);
            match l.joint {
                JointKind::Planar => {
                    let (s, co) = q[a + 2].sin_cos();
                    // ∂q̇/∂v and ∂q̇/∂θ.
                    jx[a * nx + nq + b + 1] = co;
                    jx[a * nx + nq + b + 2] = -s;
                    jx[(a + 1) * nx + nq + b + 1] = s;
                    jx[(a + 1) * nx + nq + b + 2] = co;
                    jx[(a + 2) * nx + nq + b] = 1.0;
                    jx[a * nx + a + 2] = -s * v[b + 1] - co * v[b + 2];
                    jx[(a + 1) * nx + a + 2] = co * v[b + 1] - s * v[b + 2];
                    // ∂v̇/∂(x, y, θ) from the tangent columns (ω, v_x, v_y).
                    for r in 0..nv {
                        let t = |k: usize| cols[(b + k) * nv + r];
                        let row = &mut jx[(nq + r) * nx..];
                        row[a] = co * t(1) - s * t(2);
                        row[a + 1] = s * t(1) + co * t(2);
                        row[a + 2] = t(0);
                    }
                }
                _ => {
                    jx[a * nx + nq + b] = 1.0;
                    for r in 0..nv {
                        jx[(nq + r) * nx + a] = cols[b * nv + r];
                    }
                }
            }
        }
        self.cols = cols;
    }

    /// RNEA at the computed accelerations: link accelerations and subtree forces.
    fn rnea(&mut self, v: &[f64], vd: &[f64]) {
        let m = self.model;
        let d = &self.dynamics;
        let a0 = Motion {
            ang: Vec3::zero(),
            lin: -Vec3::from_f64(m.gravity),
        };
        for (i, l) in m.links.iter().enumerate() {
            let (mut vj, mut aj) = (Motion::zero(), Motion::zero());
            for k in 0..l.joint.nv() {
                let s = l.joint.subspace::<f64>(k);
                vj += s.scale(v[l.v_index + k]);
                aj += s.scale(vd[l.v_index + k]);
            }
            let (vp, ap) = match l.parent {
                Some(p) => (d.vel[p], self.acc[p]),
                None => (Motion::zero(), a0),
            };
            self.vj[i] = vj;
            self.xv[i] = d.up[i].apply_motion(&vp);
            self.xa[i] = d.up[i].apply_motion(&ap);
            self.acc[i] = self.xa[i] + d.vel[i].cross_motion(&vj) + aj;
            let body = &self.inertia[i];
            self.momentum[i] = body.mul_motion(&d.vel[i]);
            self.subtree[i] = body.mul_motion(&self.acc[i])
                + d.vel[i].cross_force(&self.momentum[i])
                - self.f_ext[i];
        }
        for i in (0..m.links.len()).rev() {
            if let Some(p) = m.links[i].parent {
                let f = d.up[i].tr_apply_force(&self.subtree[i]);
                self.subtree[p] += f;
            }
        }
    }

    /// Partials of the contact law at every contact point.
    fn linearize_contacts(&mut self) {
        let m = self.model;
        let cp = &m.contact;
        self.contacts.clear();
        for (j, l) in m.links.iter().enumerate() {
            let e = self.dynamics.world[j].e;
            let vel = self.dynamics.vel[j];
            for point in &l.contacts {
                let p = Vec3(*point);
                let pos = self.dynamics.point_position(j, &p);
                let u = vel.lin + vel.ang.cross(&p);
                let pvel = e.tr_mul_vec(&u);
                let f_w = contact_force(cp, &pos, &pvel);
                let h = pos.0[1] - cp.ground;
                let [vx, vy, vz] = pvel.0;
                let spring = ((h - cp.spring_offset) * -cp.spring_rate).exp() * cp.spring_force;
                let d_spring = -cp.spring_rate * spring;
                let big = ((h - cp.damping_offset) * cp.damping_rate).exp() * cp.damping_factor;
                let g = (big + 1.0).recip();
                let d_g = -cp.damping_rate * big * g * g;
                let slip = (vx * vx + vz * vz + cp.slip_speed * cp.slip_speed).sqrt();
                let scale = -(spring * cp.friction) / slip;
                let d_scale_h = -(d_spring * cp.friction) / slip;
                let d_scale_v = spring * cp.friction / (slip * slip * slip);
                let (dsx, dsz) = (d_scale_v * vx, d_scale_v * vz);
                self.contacts.push(ContactPoint {
                    link: j,
                    p,
                    f_link: e.mul_vec(&f_w),
                    u,
                    d_height: [
                        vx * d_scale_h,
                        d_spring - cp.damping * vy * d_g,
                        vz * d_scale_h,
                    ],
                    d_vel: [
                        [scale + vx * dsx, 0.0, vx * dsz],
                        [0.0, -cp.damping * g, 0.0],
                        [vz * dsx, 0.0, scale + vz * dsz],
                    ],
                });
            }
        }
    }

    /// Joint-space mass matrix by the composite-rigid-body algorithm into `chol`.
    fn mass_matrix(&mut self) {
        let m = self.model;
        let nv = m.nv;
        let up = &self.dynamics.up;
        self.chol.fill(0.0);
        self.composite.copy_from_slice(&self.body_blocks);
        for i in (0..m.links.len()).rev() {
            if let Some(p) = m.links[i].parent {
                let t = self.composite[i].transform_back(&up[i]);
                self.composite[p] += t;
            }
        }
        for (i, li) in m.links.iter().enumerate() {
            for k in 0..li.joint.nv() {
                let row = li.v_index + k;
                let mut f = self.composite[i].mul_motion(&li.joint.subspace(k));
                for kk in 0..li.joint.nv() {
                    self.chol[row * nv + li.v_index + kk] = li.joint.subspace::<f64>(kk).dot(&f);
                }
                let mut j = i;
                while let Some(p) = m.links[j].parent {
                    f = up[j].tr_apply_force(&f);
                    j = p;
                    let lj = &m.links[j];
                    for kk in 0..lj.joint.nv() {
                        let val = lj.joint.subspace::<f64>(kk).dot(&f);
                        self.chol[row * nv + lj.v_index + kk] = val;
                        self.chol[(lj.v_index + kk) * nv + row] = val;
                    }
                }
            }
        }
    }

    /// `∂(−RNEA)/∂` (position tangent or velocity) along column `k` of joint `i`, into `out`.
    fn tangent(&mut self, i: usize, k: usize, position: bool, out: &mut [f64]) {
        let m = self.model;
        let d = &self.dynamics;
        let links = &m.links;
        let s = self.columns[links[i].v_index + k].1;
        let neg = |x: Motion<f64>| x.scale(-1.0);
        self.inside[..i].fill(false);
        self.df[..i].fill(Force::zero());
        for j in i..links.len() {
            self.inside[j] = j == i || links[j].parent.is_some_and(|p| self.inside[p]);
            if !self.inside[j] {
                self.df[j] = Force::zero();
                continue;
            }
            let (vel, vj) = (d.vel[j], self.vj[j]);
            let (dv, da, xi) = if j == i {
                if position {
                    let dv = neg(s.cross_motion(&self.xv[j]));
                    let da = neg(s.cross_motion(&self.xa[j])) + dv.cross_motion(&vj);
                    (dv, da, s)
                } else {
                    let da = s.cross_motion(&vj) + vel.cross_motion(&s);
                    (s, da, Motion::zero())
                }
            } else {
                let p = links[j].parent.unwrap_or(0);
                let x = &d.up[j];
                let dv = x.apply_motion(&self.dv[p]);
                let da = x.apply_motion(&self.da[p]) + dv.cross_motion(&vj);
                let xi = if position && self.touches[j] {
                    x.apply_motion(&self.xi[p])
                } else {
                    Motion::zero()
                };
                (dv, da, xi)
            };
            self.dv[j] = dv;
            self.da[j] = da;
            self.xi[j] = xi;
            let body = &self.inertia[j];
            self.df[j] = body.mul_motion(&da)
                + dv.cross_force(&self.momentum[j])
                + vel.cross_force(&body.mul_motion(&dv));
        }
        for c in &self.contacts {
            let j = c.link;
            if !self.inside[j] {
                continue;
            }
            let (dv, xi) = (self.dv[j], self.xi[j]);
            let e = &d.world[j].e;
            let dpos = e.tr_mul_vec(&(xi.lin + xi.ang.cross(&c.p)));
            let dvel = e.tr_mul_vec(&(dv.lin + dv.ang.cross(&c.p) + xi.ang.cross(&c.u)));
            let df_w = Vec3(std::array::from_fn(|r| {
                c.d_height[r] * dpos.0[1]
                    + c.d_vel[r][0] * dvel.0[0]
                    + c.d_vel[r][1] * dvel.0[1]
                    + c.d_vel[r][2] * dvel.0[2]
            }));
            let df_link = e.mul_vec(&df_w) - xi.ang.cross(&c.f_link);
            self.df[j] = self.df[j] - Force::at_point(&c.p, &df_link);
        }
        for j in (0..links.len()).rev() {
            if let Some(p) = links[j].parent {
                let mut f = self.df[j];
                if position && j == i {
                    f += s.cross_force(&self.subtree[j]);
                }
                let f = d.up[j].tr_apply_force(&f);
                self.df[p] += f;
            }
        }
        for (o, (j, col)) in out.iter_mut().zip(&self.columns) {
            *o = -col.dot(&self.df[*j]);
        }
    }
}

/// For each link, whether it or a descendant has contact points.
fn subtree_contacts(model: &Model) -> Vec<bool> {
    let mut out: Vec<bool> = model.links.iter().map(|l| !l.contacts.is_empty()).collect();
    for i in (0..model.links.len()).rev() {
        if let Some(p) = model.links[i].parent {
            out[p] |= out[i];
        }
    }
    out
}

/// `∂τ/∂q` of [`crate::gait::character::Limits::torque`]:
/// `−k·(σ((lower − q)/w) + σ((q − upper)/w))`, `σ` the logistic function.
fn limit_stiffness(lim: &crate::gait::character::Limits, q: f64) -> f64 {
    let w = lim.width;
    -lim.stiffness * (logistic((lim.lower - q) / w) + logistic((q - lim.upper) / w))
}

/// `1/(1 + e^(−x))` without overflow.
fn logistic(x: f64) -> f64 {
    if x >= 0.0 {
        1.0 / (1.0 + (-x).exp())
    } else {
        let e = x.exp();
        e / (1.0 + e)
    }
}

/// In-place Cholesky factor `L` (lower triangle, row-major) of an SPD `n × n` matrix.
fn cholesky(n: usize, a: &mut [f64]) {
    for j in 0..n {
        let mut djj = a[j * n + j];
        for k in 0..j {
            djj -= a[j * n + k] * a[j * n + k];
        }
        let ljj = djj.sqrt();
        a[j * n + j] = ljj;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / ljj;
        }
    }
}

/// Solves `L·Lᵀ·x = b` in place.
fn cholesky_solve(n: usize, l: &[f64], b: &mut [f64]) {
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s / l[i * n + i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::sim::{Simulator, State};
    use num_dual::DualSVec64;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::path::PathBuf;

    type D = DualSVec64<24>;

    fn problem(name: &str) -> crate::gait::Problem {
        let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("problems/gait");
        crate::gait::load(&dir.join(format!("{name}.toml"))).expect("problem loads")
    }

    /// A random state whose lowest contact point is `clearance` (m) above the ground.
    fn state_near_ground(m: &Model, rng: &mut ChaCha8Rng, clearance: f64) -> State<f64> {
        let mut q: Vec<f64> = (0..m.nq).map(|_| rng.random_range(-0.6..0.6)).collect();
        let v: Vec<f64> = (0..m.nv).map(|_| rng.random_range(-1.5..1.5)).collect();
        let mut d = Dynamics::<f64>::new(m);
        d.kinematics(m, &q, &v);
        let lowest = m
            .links
            .iter()
            .enumerate()
            .flat_map(|(i, l)| l.contacts.iter().map(move |p| (i, *p)))
            .map(|(i, p)| d.point_position(i, &Vec3(p)).0[1])
            .fold(f64::INFINITY, f64::min);
        q[m.links[0].q_index + 1] += m.contact.ground + clearance - lowest;
        State { q, v }
    }

    /// Jacobians of `Simulator::derivative` by dual numbers (`nx + na ≤ 24` directions).
    fn dual_jacobians(m: &Model, x: &State<f64>, act: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let (nq, nv, na) = (m.nq, m.nv, m.actuators.len());
        let nx = nq + nv;
        let xd = State {
            q: (0..nq).map(|i| D::from_re(x.q[i]).derivative(i)).collect(),
            v: (0..nv)
                .map(|i| D::from_re(x.v[i]).derivative(nq + i))
                .collect(),
        };
        let controls = |_t: f64, out: &mut [D]| {
            for (a, o) in out.iter_mut().enumerate() {
                *o = D::from_re(act[a]).derivative(nx + a);
            }
        };
        let mut sim = Simulator::<D>::new(m);
        let (mut qd, mut vd) = (vec![D::from_re(0.0); nq], vec![D::from_re(0.0); nv]);
        sim.derivative(0.0, &xd, &controls, &mut qd, &mut vd);
        let eps = |z: &D, d: usize| z.eps.0.as_ref().map_or(0.0, |e| e[d]);
        let out: Vec<&D> = qd.iter().chain(&vd).collect();
        let jx = out
            .iter()
            .flat_map(|z| (0..nx).map(move |j| eps(z, j)))
            .collect();
        let ju = out
            .iter()
            .flat_map(|z| (0..na).map(move |a| eps(z, nx + a)))
            .collect();
        (jx, ju)
    }

    #[test]
    fn stage_jacobians_match_dual_numbers_with_contact() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for name in ["pogo_jump", "luxo_leap", "biped_hop"] {
            let p = problem(name);
            let m = &p.model;
            let (nq, nv, na) = (m.nq, m.nv, m.actuators.len());
            let nx = nq + nv;
            let mut lin = StageLinearizer::new(m).expect("no floating joint");
            let mut worst: f64 = 0.0;
            for trial in 0..12 {
                // Clearances from 2 mm below to 8 mm above the ground: contact active.
                let x = state_near_ground(m, &mut rng, -0.002 + 0.001 * trial as f64 * 0.8);
                let act: Vec<f64> = (0..na).map(|_| rng.random_range(-3.0..3.0)).collect();
                let (mut qd, mut vd) = (vec![0.0; nq], vec![0.0; nv]);
                let (mut jx, mut ju) = (vec![0.0; nx * nx], vec![0.0; nx * na]);
                lin.evaluate(&x.q, &x.v, &act, &mut qd, &mut vd, &mut jx, &mut ju);
                let mut sim = Simulator::<f64>::new(m);
                let (mut qd0, mut vd0) = (vec![0.0; nq], vec![0.0; nv]);
                let ctl = |_t: f64, out: &mut [f64]| out.copy_from_slice(&act);
                sim.derivative(0.0, &x, &ctl, &mut qd0, &mut vd0);
                assert_eq!(
                    (&qd, &vd),
                    (&qd0, &vd0),
                    "{name}: f differs from the simulator"
                );
                let (jx_d, ju_d) = dual_jacobians(m, &x, &act);
                let scale = jx_d.iter().chain(&ju_d).fold(1.0f64, |s, v| s.max(v.abs()));
                for (a, b) in jx.iter().zip(&jx_d).chain(ju.iter().zip(&ju_d)) {
                    worst = worst.max((a - b).abs() / scale);
                }
            }
            println!("{name}: max |analytical − dual| / max|J| = {worst:.2e}");
            assert!(worst < 1e-12, "{name}: {worst}");
        }
    }
}
