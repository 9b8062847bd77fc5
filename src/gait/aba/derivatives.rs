//! Analytical first derivatives of the state derivative `f(x, u) = (q̇, v̇)` of
//! [`crate::gait::sim`] with respect to the state `x = (q, v)` and the actuator forces `u`, in
//! `f64`: the Carpentier–Mansard (2018) route, `∂v̇/∂x = M⁻¹·∂(τ − RNEA(q, v, v̇*))/∂x`,
//! `∂v̇/∂u = M⁻¹·B`, with `v̇*` the articulated-body solution held fixed (implicit function
//! theorem on `M(q)·v̇ + C(q, v) = τ(q, v, u)`).
//!
//! All directions at once, in world coordinates (Carpentier & Mansard 2018, "Analytical
//! derivatives of rigid body dynamics algorithms", RSS). With every spatial quantity in world
//! coordinates, `S_c` the motion-subspace column of velocity coordinate `c` on link `L(c)`,
//! `v_j`, `a_j` (including the fictitious `a₀ = [0; −g]`), `I_j`, `h_j = I_j·v_j`,
//! `f_j = I_j·a_j + v_j ×* h_j − f_ext,j` and the subtree sums `F_k = Σ_{j ⪰ k} f_j`, a
//! configuration tangent along column `i` moves link `L(i)` and its subtree rigidly by the world
//! twist `ε = S_i`; with `v_p`, `a_p` the velocity and acceleration of `L(i)`'s parent (`0`, `a₀`
//! at the root), for links `j` in the subtree:
//! ```text
//!   position:  δv_j = ε × v_j − w,  δa_j = ε × a_j − α − w × (v_j − v_p),  δI_j = ε ×* I_j − I_j·ε×
//!              w = ε × v_p,  α = ε × a_p
//!   velocity:  δv_j = ε,            δa_j = ε × v_j − β,   β = ε × (v_L(i) + v_p)
//!   ⇒ δf_j = ε ×* f_j − I_j·(α − w × v_p) − B_j·w + K_j·ε      (position)
//!      δf_j = B_j·ε − I_j·β                                      (velocity)
//!   B_j·ε = I_j·(ε × v_j) + ε ×* h_j + v_j ×* (I_j·ε) + Σ_contacts −Pᵀ D_v P·ε
//!   K_j·ε = Σ_contacts −Pᵀ·(D_h·(P·ε)_y + D_v·(ω_ε × u) + F × ω_ε)
//! ```
//! where, per contact point at world `p` with world velocity `u` and force `F` (seed eq.
//! 3.26–3.27 and the friction of [`crate::gait::contact`]), `P·ε = ε_lin + ε_ang × p` is the
//! point's displacement, `Pᵀ·f = [p × f; f]`, `D_h = ∂F/∂p_y`, `D_v = ∂F/∂ṗ`. Summed over
//! subtrees (plain sums in world coordinates: `Iᶜ_k`, `Bᶜ_k`, `Kᶜ_k`), and with
//! `δS_c·F + S_c·(ε ×* F) = 0` for columns that move with the tangent:
//! ```text
//!   L(c) in the subtree of L(i):  δτ_c = S_c·(−Iᶜ·(α − w × v_p) − Bᶜ·w + Kᶜ·ε)  at L(c)
//!                                  δτ_c = S_c·(Bᶜ·ε − Iᶜ·β)                       (velocity)
//!   L(c) a strict ancestor:        δτ_c = S_c·(ε ×* F + the same bracket at L(i))
//! ```
//! so the `2·nv` right-hand-side columns cost one dot product per pair after an O(n) set-up,
//! and the mass matrix is `M_cd = S_dᵀ·Iᶜ_{L(c)}·S_c` (CRBA in world coordinates). Passive
//! springs, dampers and limit springs add `∂τ_p/∂q`, `∂τ_p/∂q̇` on their scalar joints, and a
//! position servo ([`crate::gait::character::Servo`]) its `∂τ/∂q`, `∂τ/∂q̇` likewise, its
//! actuator column being `∂τ/∂u` instead of 1.
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
use crate::gait::character::{ForcePartials, JointKind, Model};
use crate::gait::spatial::{ArticulatedInertia, Force, Mat3, Motion, Vec3};

/// A spatial vector `[angular; linear]` in world coordinates.
type V6 = [f64; 6];
/// A 6×6 matrix (row-major) mapping motion vectors to force vectors.
type M6 = [[f64; 6]; 6];

/// Reusable evaluator of `f(x, u)` and its Jacobians for one model.
#[derive(Debug, Clone)]
pub struct StageLinearizer<'m> {
    model: &'m Model,
    dynamics: Dynamics<f64>,
    f_ext: Vec<Force<f64>>,
    tau: Vec<f64>,
    /// Each link's own spatial inertia (link coordinates, constant).
    body: Vec<ArticulatedInertia<f64>>,
    /// World-coordinate link velocity and acceleration.
    vel: Vec<V6>,
    acc: Vec<V6>,
    /// Subtree force sums `F_k` (world).
    force: Vec<V6>,
    /// Subtree sums of `I_j`, `B_j` and `K_j` (world).
    inertia: Vec<M6>,
    coriolis: Vec<M6>,
    contact: Vec<M6>,
    /// Per velocity coordinate: `S_c`, `Iᶜ·S_c`, `Bᶜᵀ·S_c`, `Kᶜᵀ·S_c` at its link (world).
    s: Vec<V6>,
    s_inertia: Vec<V6>,
    s_coriolis: Vec<V6>,
    s_contact: Vec<V6>,
    /// Mass matrix, then its Cholesky factor (row-major nv × nv).
    chol: Vec<f64>,
    /// Reciprocals of the Cholesky factor's diagonal.
    inv_diag: Vec<f64>,
    /// Right-hand sides / solutions, row-major nv × (2nv + na).
    cols: Vec<f64>,
    /// Each velocity coordinate's link and motion-subspace column (link coordinates).
    columns: Vec<(usize, Motion<f64>)>,
    /// `below[j·n + i]`: link `j` is `i` or one of its descendants.
    below: Vec<bool>,
    /// Per actuator, its force and partials at the last [`StageLinearizer::evaluate`].
    pub forces: Vec<ForcePartials>,
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
        let mut below = vec![false; n * n];
        for j in 0..n {
            let mut k = Some(j);
            while let Some(i) = k {
                below[j * n + i] = true;
                k = model.links[i].parent;
            }
        }
        Some(StageLinearizer {
            model,
            dynamics: Dynamics::new(model),
            f_ext: vec![Force::zero(); n],
            tau: vec![0.0; nv],
            body: model
                .links
                .iter()
                .map(|l| l.inertia_t::<f64>().to_articulated())
                .collect(),
            vel: vec![[0.0; 6]; n],
            acc: vec![[0.0; 6]; n],
            force: vec![[0.0; 6]; n],
            inertia: vec![[[0.0; 6]; 6]; n],
            coriolis: vec![[[0.0; 6]; 6]; n],
            contact: vec![[[0.0; 6]; 6]; n],
            s: vec![[0.0; 6]; nv],
            s_inertia: vec![[0.0; 6]; nv],
            s_coriolis: vec![[0.0; 6]; nv],
            s_contact: vec![[0.0; 6]; nv],
            chol: vec![0.0; nv * nv],
            inv_diag: vec![0.0; nv],
            cols: vec![0.0; nv * (2 * nv + model.actuators.len())],
            columns: model
                .links
                .iter()
                .enumerate()
                .flat_map(|(i, l)| (0..l.joint.nv()).map(move |k| (i, l.joint.subspace(k))))
                .collect(),
            below,
            forces: vec![
                ForcePartials {
                    force: 0.0,
                    d_control: 1.0,
                    d_position: 0.0,
                    d_rate: 0.0,
                };
                model.actuators.len()
            ],
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
        self.contacts();
        self.tau.fill(0.0);
        m.add_passive(q, v, &mut self.tau);
        for ((a, u), out) in m.actuators.iter().zip(act).zip(&mut self.forces) {
            let l = &m.links[a.link];
            *out = a.force_partials(*u, q[l.q_index], v[l.v_index]);
            self.tau[l.v_index] += out.force;
        }
        m.qdot(q, v, qd);
        self.dynamics.accelerations(m, &self.tau, &self.f_ext, vd);

        self.world_rnea(v, vd);
        self.subtree_sums();
        self.mass_matrix();
        cholesky(nv, &mut self.chol, &mut self.inv_diag);

        // Right-hand sides: ∂(τ_p − RNEA)/∂(δ, v) and the actuator columns.
        let mut cols = std::mem::take(&mut self.cols);
        cols.fill(0.0);
        self.rnea_partials(&mut cols);
        let nc = 2 * nv + na;
        for l in &m.links {
            if l.joint.is_scalar() {
                let (qi, c) = (q[l.q_index], l.v_index);
                if let Some(s) = l.spring {
                    cols[c * nc + c] -= s.stiffness;
                    cols[c * nc + nv + c] -= s.damping;
                }
                if let Some(lim) = l.limits {
                    cols[c * nc + c] += limit_stiffness(&lim, qi);
                }
            }
        }
        for (a, (act, f)) in m.actuators.iter().zip(&self.forces).enumerate() {
            let c = m.links[act.link].v_index;
            cols[c * nc + 2 * nv + a] = f.d_control;
            cols[c * nc + c] += f.d_position;
            cols[c * nc + nv + c] += f.d_rate;
        }
        cholesky_solve(nv, nc, &self.chol, &self.inv_diag, &mut cols);

        // Assemble jx = [[∂q̇/∂q, ∂q̇/∂v], [∂v̇/∂q, ∂v̇/∂v]] and ju = [0; ∂v̇/∂u].
        jx.fill(0.0);
        ju.fill(0.0);
        for r in 0..nv {
            let row = &mut jx[(nq + r) * nx..(nq + r + 1) * nx];
            for c in 0..nv {
                row[nq + c] = cols[r * nc + nv + c];
            }
            for a in 0..na {
                ju[(nq + r) * na + a] = cols[r * nc + 2 * nv + a];
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
                        let t = |k: usize| cols[r * nc + b + k];
                        let row = &mut jx[(nq + r) * nx..];
                        row[a] = co * t(1) - s * t(2);
                        row[a + 1] = s * t(1) + co * t(2);
                        row[a + 2] = t(0);
                    }
                }
                _ => {
                    jx[a * nx + nq + b] = 1.0;
                    for r in 0..nv {
                        jx[(nq + r) * nx + a] = cols[r * nc + b];
                    }
                }
            }
        }
        self.cols = cols;
    }
    /// RNEA at the computed accelerations `vd` in world coordinates: per link `S_c`, `v_j`,
    /// `a_j`, `I_j`, `f_j`, and the velocity terms of `B_j` (added to the contact terms of
    /// [`Self::contacts`]).
    fn world_rnea(&mut self, v: &[f64], vd: &[f64]) {
        let m = self.model;
        let d = &self.dynamics;
        let a0 = [0.0, 0.0, 0.0, -m.gravity[0], -m.gravity[1], -m.gravity[2]];
        for (j, l) in m.links.iter().enumerate() {
            let x = &d.world[j];
            let vel = m6(&x.inv_apply_motion(&d.vel[j]));
            let (vp, ap) = match l.parent {
                Some(p) => (self.vel[p], self.acc[p]),
                None => ([0.0; 6], a0),
            };
            // a_j = a_p + v_p × v_J + S·q̈ (v_j × v_J = v_p × v_J).
            let mut vj = [0.0; 6];
            let mut acc = ap;
            for k in 0..l.joint.nv() {
                let c = l.v_index + k;
                let s = m6(&x.inv_apply_motion(&self.columns[c].1));
                self.s[c] = s;
                for r in 0..6 {
                    vj[r] += s[r] * v[c];
                    acc[r] += s[r] * vd[c];
                }
            }
            let vpj = cross_motion(&vp, &vj);
            for r in 0..6 {
                acc[r] += vpj[r];
            }
            self.vel[j] = vel;
            self.acc[j] = acc;
            let blocks = self.body[j].transform_back(x);
            let inertia = inertia_matrix(&blocks);
            let h = mat_vec(&inertia, &vel);
            let ia = mat_vec(&inertia, &acc);
            let vh = cross_force(&vel, &h);
            let fe = f6(&x.tr_apply_force(&self.f_ext[j]));
            self.force[j] = std::array::from_fn(|r| ia[r] + vh[r] - fe[r]);
            // B_j = −T − Tᵀ + H with T = I·crm(v) (so I·(ε × v) = −T·ε and
            // v ×* (I·ε) = crf(v)·I·ε = −Tᵀ·ε) and H·ε = ε ×* h.
            let (w, vl) = (
                Vec3([vel[0], vel[1], vel[2]]),
                Vec3([vel[3], vel[4], vel[5]]),
            );
            let (ia_, ib, ic) = (&blocks.a, &blocks.b, &blocks.c);
            let t00 = ia_.mul_skew(&w) + ib.mul_skew(&vl);
            let t01 = ib.mul_skew(&w);
            let t10 = ib.transpose().mul_skew(&w) + ic.mul_skew(&vl);
            let t11 = ic.mul_skew(&w);
            let hn = Mat3::skew(&Vec3([h[0], h[1], h[2]]));
            let hf = Mat3::skew(&Vec3([h[3], h[4], h[5]]));
            let b = &mut self.coriolis[j];
            add_block(b, 0, 0, &neg_sum(&[&t00, &t00.transpose(), &hn]));
            add_block(b, 0, 3, &neg_sum(&[&t01, &t10.transpose(), &hf]));
            add_block(b, 3, 0, &neg_sum(&[&t10, &t01.transpose(), &hf]));
            add_block(b, 3, 3, &neg_sum(&[&t11, &t11.transpose()]));
            self.inertia[j] = inertia;
        }
    }

    /// The contact forces `f_ext` (link coordinates, as [`crate::gait::contact`] computes them)
    /// and their partials: `B_j` starts as `Σ −Pᵀ·D_v·P` over its contact points, `K_j` as
    /// their position terms.
    fn contacts(&mut self) {
        let m = self.model;
        let cp = &m.contact;
        let d = &self.dynamics;
        self.coriolis.fill([[0.0; 6]; 6]);
        self.contact.fill([[0.0; 6]; 6]);
        self.f_ext.fill(Force::zero());
        for (j, l) in m.links.iter().enumerate() {
            for point in &l.contacts {
                let p_link = Vec3(*point);
                let p = d.point_position(j, &p_link).0;
                let u = d.point_velocity(j, &p_link);
                let h = p[1] - cp.ground;
                let [vx, vy, vz] = u.0;
                let u = u.0;
                // The force exactly as `contact::contact_force` computes it.
                let spring = ((h - cp.spring_offset) * -cp.spring_rate).exp() * cp.spring_force;
                let big = ((h - cp.damping_offset) * cp.damping_rate).exp() * cp.damping_factor;
                let g = (big + 1.0).recip();
                let slip = (vx * vx + vz * vz + cp.slip_speed * cp.slip_speed).sqrt();
                let scale = -(spring * cp.friction) / slip;
                let f_w = [vx * scale, spring - vy * g * cp.damping, vz * scale];
                let f_link = d.world[j].e.mul_vec(&Vec3(f_w));
                self.f_ext[j] += Force::at_point(&p_link, &f_link);
                let d_spring = -cp.spring_rate * spring;
                let d_g = -cp.damping_rate * big * g * g;
                let d_scale_h = -(d_spring * cp.friction) / slip;
                let d_scale_v = spring * cp.friction / (slip * slip * slip);
                let (dsx, dsz) = (d_scale_v * vx, d_scale_v * vz);
                // ∂F/∂p_y and ∂F/∂ṗ (world; rows = force components).
                let d_h = [
                    vx * d_scale_h,
                    d_spring - cp.damping * vy * d_g,
                    vz * d_scale_h,
                ];
                let d_v = [
                    [scale + vx * dsx, 0.0, vx * dsz],
                    [0.0, -cp.damping * g, 0.0],
                    [vz * dsx, 0.0, scale + vz * dsz],
                ];
                let d_v = Mat3(d_v);
                // −Pᵀ·D_v·P into B_j, P = [−[p]×, 1], Pᵀ·y = [p × y; y].
                let pv = Vec3(p);
                let dp = d_v.mul_skew(&pv);
                let b = &mut self.coriolis[j];
                add_block(b, 0, 0, &Mat3::skew_mul(&pv, &dp));
                add_block(b, 0, 3, &neg_sum(&[&Mat3::skew_mul(&pv, &d_v)]));
                add_block(b, 3, 0, &dp);
                add_block(b, 3, 3, &neg_sum(&[&d_v]));
                // K_j += −Pᵀ·G, G·ε = D_h·(P·ε)_y + D_v·(ω × u) + F × ω = [G_a, D_h·e_yᵀ]·ε.
                let (px, pz) = (p[0], p[2]);
                let g_a = Mat3(std::array::from_fn(|r| [-d_h[r] * pz, 0.0, d_h[r] * px]))
                    + Mat3::skew(&Vec3(f_w))
                    - d_v.mul_skew(&Vec3(u));
                let k = &mut self.contact[j];
                add_block(k, 0, 0, &neg_sum(&[&Mat3::skew_mul(&pv, &g_a)]));
                add_block(k, 3, 0, &neg_sum(&[&g_a]));
                let pd = pv.cross(&Vec3(d_h));
                for r in 0..3 {
                    k[r][4] -= pd.0[r];
                    k[r + 3][4] -= d_h[r];
                }
            }
        }
    }

    /// Subtree sums of `f`, `I`, `B`, `K` and the per-column products `Iᶜ·S`, `Bᶜᵀ·S`, `Kᶜᵀ·S`.
    fn subtree_sums(&mut self) {
        let m = self.model;
        for i in (0..m.links.len()).rev() {
            if let Some(p) = m.links[i].parent {
                let (lo, hi) = self.force.split_at_mut(i);
                add6(&mut lo[p], &hi[0]);
                for mats in [&mut self.inertia, &mut self.coriolis, &mut self.contact] {
                    let (lo, hi) = mats.split_at_mut(i);
                    add66(&mut lo[p], &hi[0]);
                }
            }
        }
        for (c, &(l, _)) in self.columns.iter().enumerate() {
            let s = &self.s[c];
            self.s_inertia[c] = mat_vec(&self.inertia[l], s);
            self.s_coriolis[c] = mat_tr_vec(&self.coriolis[l], s);
            self.s_contact[c] = mat_tr_vec(&self.contact[l], s);
        }
    }

    /// Joint-space mass matrix `M_cd = S_dᵀ·Iᶜ_{L(c)}·S_c` (`L(d)` an ancestor of or equal to
    /// `L(c)`) into `chol`.
    fn mass_matrix(&mut self) {
        let (nv, n) = (self.model.nv, self.model.links.len());
        self.chol.fill(0.0);
        for c in 0..nv {
            let lc = self.columns[c].0;
            for e in 0..nv {
                let le = self.columns[e].0;
                if self.below[lc * n + le] {
                    let val = dot6(&self.s[e], &self.s_inertia[c]);
                    self.chol[c * nv + e] = val;
                    self.chol[e * nv + c] = val;
                }
            }
        }
    }

    /// `∂(−RNEA)/∂` along every position tangent and velocity coordinate: columns `i` and
    /// `nv + i` of the row-major `nv × (2nv + na)` matrix `cols` (entries not reached stay as
    /// they are: the caller zeroes them).
    fn rnea_partials(&self, cols: &mut [f64]) {
        let m = self.model;
        let (nv, n) = (m.nv, m.links.len());
        let nc = 2 * nv + m.actuators.len();
        let a0 = [0.0, 0.0, 0.0, -m.gravity[0], -m.gravity[1], -m.gravity[2]];
        for i in 0..nv {
            let li = self.columns[i].0;
            let eps = &self.s[i];
            let parent = m.links[li].parent;
            let has_parent = parent.is_some();
            let (vp, ap) = match parent {
                Some(p) => (self.vel[p], self.acc[p]),
                None => ([0.0; 6], a0),
            };
            let w = cross_motion(eps, &vp);
            let alpha = cross_motion(eps, &ap);
            let wvp = cross_motion(&w, &vp);
            let z: V6 = std::array::from_fn(|r| alpha[r] - wvp[r]);
            let vsum: V6 = std::array::from_fn(|r| self.vel[li][r] + vp[r]);
            let beta = cross_motion(eps, &vsum);
            // The brackets at L(i), for the columns of its strict ancestors (if any).
            let (y_pos, y_vel) = if has_parent {
                let (ic, bc, kc) = (&self.inertia[li], &self.coriolis[li], &self.contact[li]);
                let (iz, bw, ke, be, ib) = (
                    mat_vec(ic, &z),
                    mat_vec(bc, &w),
                    mat_vec(kc, eps),
                    mat_vec(bc, eps),
                    mat_vec(ic, &beta),
                );
                let ef = cross_force(eps, &self.force[li]);
                let y_pos: V6 = std::array::from_fn(|r| ef[r] - iz[r] - bw[r] + ke[r]);
                let y_vel: V6 = std::array::from_fn(|r| be[r] - ib[r]);
                (y_pos, y_vel)
            } else {
                ([0.0; 6], [0.0; 6])
            };
            for c in 0..nv {
                let lc = self.columns[c].0;
                let row = &mut cols[c * nc..];
                if self.below[lc * n + li] {
                    row[i] = dot6(&self.s_inertia[c], &z) + dot6(&self.s_coriolis[c], &w)
                        - dot6(&self.s_contact[c], eps);
                    row[nv + i] = dot6(&self.s_inertia[c], &beta) - dot6(&self.s_coriolis[c], eps);
                } else if self.below[li * n + lc] {
                    row[i] = -dot6(&self.s[c], &y_pos);
                    row[nv + i] = -dot6(&self.s[c], &y_vel);
                }
            }
        }
    }
}

/// `[ang; lin]` of a motion vector.
fn m6(x: &Motion<f64>) -> V6 {
    [
        x.ang.0[0], x.ang.0[1], x.ang.0[2], x.lin.0[0], x.lin.0[1], x.lin.0[2],
    ]
}

/// `[ang; lin]` of a force vector.
fn f6(x: &Force<f64>) -> V6 {
    [
        x.ang.0[0], x.ang.0[1], x.ang.0[2], x.lin.0[0], x.lin.0[1], x.lin.0[2],
    ]
}

fn cross3(a: &[f64; 3], b: &[f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Motion cross product `a ×m b`.
fn cross_motion(a: &V6, b: &V6) -> V6 {
    let (aw, av) = ([a[0], a[1], a[2]], [a[3], a[4], a[5]]);
    let (bw, bv) = ([b[0], b[1], b[2]], [b[3], b[4], b[5]]);
    let ang = cross3(&aw, &bw);
    let (l1, l2) = (cross3(&aw, &bv), cross3(&av, &bw));
    [
        ang[0],
        ang[1],
        ang[2],
        l1[0] + l2[0],
        l1[1] + l2[1],
        l1[2] + l2[2],
    ]
}

/// Force cross product `a ×f f`.
fn cross_force(a: &V6, f: &V6) -> V6 {
    let (aw, av) = ([a[0], a[1], a[2]], [a[3], a[4], a[5]]);
    let (fn_, ff) = ([f[0], f[1], f[2]], [f[3], f[4], f[5]]);
    let (n1, n2) = (cross3(&aw, &fn_), cross3(&av, &ff));
    let lin = cross3(&aw, &ff);
    [
        n1[0] + n2[0],
        n1[1] + n2[1],
        n1[2] + n2[2],
        lin[0],
        lin[1],
        lin[2],
    ]
}

fn dot6(a: &V6, b: &V6) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] + a[4] * b[4] + a[5] * b[5]
}

fn mat_vec(m: &M6, v: &V6) -> V6 {
    std::array::from_fn(|r| dot6(&m[r], v))
}

fn mat_tr_vec(m: &M6, v: &V6) -> V6 {
    std::array::from_fn(|c| (0..6).map(|r| m[r][c] * v[r]).sum())
}

fn add6(a: &mut V6, b: &V6) {
    for r in 0..6 {
        a[r] += b[r];
    }
}

fn add66(a: &mut M6, b: &M6) {
    for r in 0..6 {
        add6(&mut a[r], &b[r]);
    }
}

/// The 6×6 matrix `[A B; Bᵀ C]` of an inertia.
fn inertia_matrix(i: &ArticulatedInertia<f64>) -> M6 {
    std::array::from_fn(|r| {
        std::array::from_fn(|c| match (r < 3, c < 3) {
            (true, true) => i.a.0[r][c],
            (true, false) => i.b.0[r][c - 3],
            (false, true) => i.b.0[c][r - 3],
            (false, false) => i.c.0[r - 3][c - 3],
        })
    })
}

/// Adds the 3×3 block `b` at row `r0`, column `c0` of `m`.
fn add_block(m: &mut M6, r0: usize, c0: usize, b: &Mat3<f64>) {
    for r in 0..3 {
        for c in 0..3 {
            m[r0 + r][c0 + c] += b.0[r][c];
        }
    }
}

/// `−Σ mᵢ`.
fn neg_sum(ms: &[&Mat3<f64>]) -> Mat3<f64> {
    let mut out = Mat3::zero();
    for m in ms {
        out = out - **m;
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

/// In-place Cholesky factor `L` (lower triangle, row-major) of an SPD `n × n` matrix, and the
/// reciprocals of its diagonal.
fn cholesky(n: usize, a: &mut [f64], inv_diag: &mut [f64]) {
    for j in 0..n {
        let mut djj = a[j * n + j];
        for k in 0..j {
            djj -= a[j * n + k] * a[j * n + k];
        }
        let ljj = djj.sqrt();
        a[j * n + j] = ljj;
        let inv = ljj.recip();
        inv_diag[j] = inv;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s * inv;
        }
    }
}

/// Solves `L·Lᵀ·X = B` in place for the row-major `n × m` right-hand sides `b` (all columns
/// at once, row operations).
fn cholesky_solve(n: usize, m: usize, l: &[f64], inv_diag: &[f64], b: &mut [f64]) {
    for i in 0..n {
        let (done, rest) = b.split_at_mut(i * m);
        let row = &mut rest[..m];
        for k in 0..i {
            let f = l[i * n + k];
            for (x, y) in row.iter_mut().zip(&done[k * m..(k + 1) * m]) {
                *x -= f * y;
            }
        }
        for x in row.iter_mut() {
            *x *= inv_diag[i];
        }
    }
    for i in (0..n).rev() {
        let (head, tail) = b.split_at_mut((i + 1) * m);
        let row = &mut head[i * m..];
        for k in i + 1..n {
            let f = l[k * n + i];
            for (x, y) in row.iter_mut().zip(&tail[(k - i - 1) * m..(k - i) * m]) {
                *x -= f * y;
            }
        }
        for x in row.iter_mut() {
            *x *= inv_diag[i];
        }
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
