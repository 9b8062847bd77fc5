//! Featherstone's articulated-body algorithm (RBDA 2008, §7.3, table 7.1): forward dynamics
//! `v̇ = ABA(q, v, τ, f_ext)` of a kinematic tree in O(n), generic over the scalar type.
//!
//! Passes, with link velocities, accelerations and forces in link coordinates:
//! 1. (`kinematics`) outward: `ⁱX_λ = X_J(qᵢ)·X_T`, `vᵢ = ⁱX_λ·v_λ + Sᵢ·q̇ᵢ`, `cᵢ = vᵢ ×m (Sᵢq̇ᵢ)`
//!    (`c_J = 0`: every joint's subspace is constant in link coordinates, see
//!    [`crate::gait::character`]); world transforms and link velocities are kept for contact
//!    and task read-outs;
//! 2. inward: `Iᴬᵢ = Iᵢ + Σ`, `pᴬᵢ = vᵢ ×f Iᵢvᵢ − f_extᵢ + Σ`, with `Uᵢ = IᴬᵢSᵢ`, `Dᵢ = SᵢᵀUᵢ`,
//!    `uᵢ = τᵢ − Sᵢᵀpᴬᵢ`, and the parent receiving `ⁱX_λᵀ(Iᴬᵢ − UᵢDᵢ⁻¹Uᵢᵀ)ⁱX_λ` and
//!    `ⁱX_λᵀ(pᴬᵢ + Iᵃᵢcᵢ + UᵢDᵢ⁻¹uᵢ)`;
//! 3. outward: `a'ᵢ = ⁱX_λ·a_λ + cᵢ`, `q̈ᵢ = Dᵢ⁻¹(uᵢ − Uᵢᵀa'ᵢ)`, `aᵢ = a'ᵢ + Sᵢq̈ᵢ`, starting
//!    from the world's fictitious acceleration `a₀ = [0; −g]` (gravity without body forces).
//!
//! External forces `f_ext` are spatial forces on each link in link coordinates (N·m, N). The
//! floating base is the six-column case `S = 1` (`D` is the full articulated inertia).

// Index loops below mirror the algorithm's subscripts (joint columns k, j of S, U and D⁻¹).
#![allow(clippy::needless_range_loop)]

pub mod derivatives;

use super::character::Model;
use super::spatial::{ArticulatedInertia, Force, Motion, Real, Vec3, Xform};

/// Scratch space and per-link results of one dynamics evaluation; reuse it across calls.
#[derive(Debug, Clone)]
pub struct Dynamics<T> {
    /// Parent-to-link transforms.
    pub up: Vec<Xform<T>>,
    /// World-to-link transforms.
    pub world: Vec<Xform<T>>,
    /// Link spatial velocities (link coordinates).
    pub vel: Vec<Motion<T>>,
    bias: Vec<Motion<T>>,
    ia: Vec<ArticulatedInertia<T>>,
    pa: Vec<Force<T>>,
    u: Vec<[Force<T>; 6]>,
    dinv: Vec<[[T; 6]; 6]>,
    rhs: Vec<[T; 6]>,
    acc: Vec<Motion<T>>,
}

impl<T: Real> Dynamics<T> {
    /// Scratch space for `model`.
    pub fn new(model: &Model) -> Self {
        let n = model.links.len();
        Dynamics {
            up: Vec::with_capacity(n),
            world: Vec::with_capacity(n),
            vel: vec![Motion::zero(); n],
            bias: vec![Motion::zero(); n],
            ia: vec![ArticulatedInertia::zero(); n],
            pa: vec![Force::zero(); n],
            u: vec![[Force::zero(); 6]; n],
            dinv: vec![[[T::zero(); 6]; 6]; n],
            rhs: vec![[T::zero(); 6]; n],
            acc: vec![Motion::zero(); n],
        }
    }

    /// Pass 1: transforms, link velocities and velocity-product accelerations at `(q, v)`.
    pub fn kinematics(&mut self, model: &Model, q: &[T], v: &[T]) {
        model.parent_transforms(q, &mut self.up);
        model.world_transforms(&self.up, &mut self.world);
        for (i, l) in model.links.iter().enumerate() {
            let mut vj = Motion::zero();
            for k in 0..l.joint.nv() {
                vj += l.joint.subspace::<T>(k).scale(v[l.v_index + k]);
            }
            let vp = match l.parent {
                Some(p) => self.up[i].apply_motion(&self.vel[p]),
                None => Motion::zero(),
            };
            self.vel[i] = vp + vj;
            self.bias[i] = self.vel[i].cross_motion(&vj);
        }
    }

    /// Passes 2 and 3: accelerations `v̇` (length nv) under generalized forces `tau` (length nv)
    /// and external link forces `f_ext` (one per link, link coordinates). Call
    /// [`Dynamics::kinematics`] first.
    pub fn accelerations(&mut self, model: &Model, tau: &[T], f_ext: &[Force<T>], vdot: &mut [T]) {
        let links = &model.links;
        for (i, l) in links.iter().enumerate() {
            let body = l.inertia_t::<T>();
            self.ia[i] = body.to_articulated();
            let h = body.mul_motion(&self.vel[i]);
            self.pa[i] = self.vel[i].cross_force(&h) - f_ext[i];
        }
        for i in (0..links.len()).rev() {
            let l = &links[i];
            let n = l.joint.nv();
            let s: [Motion<T>; 6] = std::array::from_fn(|k| {
                if k < n {
                    l.joint.subspace(k)
                } else {
                    Motion::zero()
                }
            });
            let mut d = [[T::zero(); 6]; 6];
            for k in 0..n {
                self.u[i][k] = self.ia[i].mul_motion(&s[k]);
                self.rhs[i][k] = tau[l.v_index + k] - s[k].dot(&self.pa[i]);
            }
            for j in 0..n {
                for k in 0..n {
                    d[j][k] = s[j].dot(&self.u[i][k]);
                }
            }
            invert_spd(n, &mut d);
            self.dinv[i] = d;
            if let Some(p) = l.parent {
                let u = &self.u[i][..n];
                let ia = if n == 1 {
                    self.ia[i].sub_outer(&u[0], d[0][0])
                } else {
                    self.ia[i].sub_weighted(u, &d)
                };
                let mut pa = self.pa[i] + ia.mul_motion(&self.bias[i]);
                for j in 0..n {
                    let mut coef = T::zero();
                    for k in 0..n {
                        coef += d[j][k] * self.rhs[i][k];
                    }
                    pa += u[j].scale(coef);
                }
                let x = self.up[i];
                self.ia[p] += ia.transform_back(&x);
                self.pa[p] += x.tr_apply_force(&pa);
            }
        }
        let g = Vec3::from_f64(model.gravity);
        let a0 = Motion {
            ang: Vec3::zero(),
            lin: -g,
        };
        for (i, l) in links.iter().enumerate() {
            let ap = match l.parent {
                Some(p) => self.acc[p],
                None => a0,
            };
            let a = self.up[i].apply_motion(&ap) + self.bias[i];
            let n = l.joint.nv();
            let mut r = [T::zero(); 6];
            for k in 0..n {
                r[k] = self.rhs[i][k] - a.dot(&self.u[i][k]);
            }
            let mut ai = a;
            for k in 0..n {
                let mut qdd = T::zero();
                for j in 0..n {
                    qdd += self.dinv[i][k][j] * r[j];
                }
                vdot[l.v_index + k] = qdd;
                ai += l.joint.subspace::<T>(k).scale(qdd);
            }
            self.acc[i] = ai;
        }
    }

    /// World position (m) of point `p` given in link `link`'s coordinates.
    pub fn point_position(&self, link: usize, p: &Vec3<T>) -> Vec3<T> {
        self.world[link].point_to_a(p)
    }

    /// World velocity (m/s) of the material point `p` of link `link` (link coordinates).
    pub fn point_velocity(&self, link: usize, p: &Vec3<T>) -> Vec3<T> {
        let v = &self.vel[link];
        self.world[link].e.tr_mul_vec(&(v.lin + v.ang.cross(p)))
    }

    /// Centre-of-mass position (m) and velocity (m/s) of the whole character, world frame.
    pub fn center_of_mass(&self, model: &Model) -> (Vec3<T>, Vec3<T>) {
        let (mut p, mut v, mut m) = (Vec3::zero(), Vec3::zero(), 0.0);
        for (i, l) in model.links.iter().enumerate() {
            let c = Vec3::from_f64(l.inertia.com.0);
            let mi = l.inertia.mass;
            p = p + self.point_position(i, &c).scale(T::from(mi));
            v = v + self.point_velocity(i, &c).scale(T::from(mi));
            m += mi;
        }
        (p.scale(T::from(1.0 / m)), v.scale(T::from(1.0 / m)))
    }

    /// Kinetic energy `½Σvᵢᵀ Iᵢ vᵢ` (J).
    pub fn kinetic_energy(&self, model: &Model) -> T {
        let mut e = T::zero();
        for (i, l) in model.links.iter().enumerate() {
            e += self.vel[i].dot(&l.inertia_t::<T>().mul_motion(&self.vel[i])) * 0.5;
        }
        e
    }

    /// Gravitational potential energy `−Σ mᵢ g·cᵢ` (J), zero at the world origin.
    pub fn gravity_energy(&self, model: &Model) -> T {
        let g = Vec3::from_f64(model.gravity);
        let mut e = T::zero();
        for (i, l) in model.links.iter().enumerate() {
            let c = self.point_position(i, &Vec3::from_f64(l.inertia.com.0));
            e -= g.dot(&c) * l.inertia.mass;
        }
        e
    }
}

impl super::character::Link {
    /// The link's inertia lifted to scalar type `T`.
    pub fn inertia_t<T: Real>(&self) -> super::spatial::RigidInertia<T> {
        let i = &self.inertia;
        super::spatial::RigidInertia {
            mass: T::from(i.mass),
            com: Vec3::from_f64(i.com.0),
            inertia_com: super::spatial::Mat3::from_f64(i.inertia_com.0),
        }
    }
}

/// In-place inverse of the leading `n×n` block of a symmetric positive definite matrix by
/// Gauss–Jordan elimination without pivoting (pivots of an SPD matrix are positive).
fn invert_spd<T: Real>(n: usize, a: &mut [[T; 6]; 6]) {
    for k in 0..n {
        let piv = a[k][k].recip();
        a[k][k] = T::one();
        for j in 0..n {
            a[k][j] *= piv;
        }
        for i in 0..n {
            if i != k {
                let f = a[i][k];
                a[i][k] = T::zero();
                for j in 0..n {
                    let akj = a[k][j];
                    a[i][j] -= f * akj;
                }
            }
        }
    }
}

/// Independent reference dynamics for tests: the composite-rigid-body algorithm for the mass
/// matrix `M(q)` and the recursive Newton–Euler algorithm for the bias `C(q, v)` (gravity,
/// velocity products and external forces), so that `M·v̇ = τ − C`.
#[cfg(test)]
pub mod reference {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    /// Inverse dynamics by RNEA: the `τ` that produces `vdot` at `(q, v)` under `f_ext`.
    pub fn rnea(
        model: &Model,
        q: &[f64],
        v: &[f64],
        vdot: &[f64],
        f_ext: &[Force<f64>],
    ) -> DVector<f64> {
        let n = model.links.len();
        let mut up = Vec::new();
        model.parent_transforms(q, &mut up);
        let (mut vel, mut acc, mut f) = (
            vec![Motion::zero(); n],
            vec![Motion::zero(); n],
            vec![Force::zero(); n],
        );
        let a0 = Motion {
            ang: Vec3::zero(),
            lin: -Vec3::from_f64(model.gravity),
        };
        for (i, l) in model.links.iter().enumerate() {
            let (mut vj, mut aj) = (Motion::zero(), Motion::zero());
            for k in 0..l.joint.nv() {
                vj += l.joint.subspace::<f64>(k).scale(v[l.v_index + k]);
                aj += l.joint.subspace::<f64>(k).scale(vdot[l.v_index + k]);
            }
            let (vp, ap) = match l.parent {
                Some(p) => (vel[p], acc[p]),
                None => (Motion::zero(), a0),
            };
            vel[i] = up[i].apply_motion(&vp) + vj;
            acc[i] = up[i].apply_motion(&ap) + aj + vel[i].cross_motion(&vj);
            let body = l.inertia_t::<f64>();
            f[i] =
                body.mul_motion(&acc[i]) + vel[i].cross_force(&body.mul_motion(&vel[i])) - f_ext[i];
        }
        let mut tau = DVector::zeros(model.nv);
        for i in (0..n).rev() {
            let l = &model.links[i];
            for k in 0..l.joint.nv() {
                tau[l.v_index + k] = l.joint.subspace::<f64>(k).dot(&f[i]);
            }
            if let Some(p) = l.parent {
                let fp = up[i].tr_apply_force(&f[i]);
                f[p] += fp;
            }
        }
        tau
    }

    /// The joint-space mass matrix by CRBA.
    pub fn crba(model: &Model, q: &[f64]) -> DMatrix<f64> {
        let n = model.links.len();
        let mut up = Vec::new();
        model.parent_transforms(q, &mut up);
        let mut ic: Vec<ArticulatedInertia<f64>> = model
            .links
            .iter()
            .map(|l| l.inertia_t::<f64>().to_articulated())
            .collect();
        for i in (0..n).rev() {
            if let Some(p) = model.links[i].parent {
                let t = ic[i].transform_back(&up[i]);
                ic[p] += t;
            }
        }
        let mut m = DMatrix::zeros(model.nv, model.nv);
        for i in 0..n {
            let li = &model.links[i];
            for k in 0..li.joint.nv() {
                let mut f = ic[i].mul_motion(&li.joint.subspace(k));
                let row = li.v_index + k;
                for kk in 0..li.joint.nv() {
                    m[(row, li.v_index + kk)] = li.joint.subspace::<f64>(kk).dot(&f);
                }
                let mut j = i;
                while let Some(p) = model.links[j].parent {
                    f = up[j].tr_apply_force(&f);
                    j = p;
                    let lj = &model.links[j];
                    for kk in 0..lj.joint.nv() {
                        let val = lj.joint.subspace::<f64>(kk).dot(&f);
                        m[(row, lj.v_index + kk)] = val;
                        m[(lj.v_index + kk, row)] = val;
                    }
                }
            }
        }
        m
    }

    /// `v̇ = M⁻¹(τ − C)` from CRBA and RNEA.
    pub fn forward(
        model: &Model,
        q: &[f64],
        v: &[f64],
        tau: &[f64],
        f_ext: &[Force<f64>],
    ) -> DVector<f64> {
        let bias = rnea(model, q, v, &vec![0.0; model.nv], f_ext);
        let m = crba(model, q);
        let rhs = DVector::from_column_slice(tau) - bias;
        m.cholesky()
            .expect("mass matrix is positive definite")
            .solve(&rhs)
    }
}
