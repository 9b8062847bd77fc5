//! 6-D spatial vector algebra in Featherstone's notation (Rigid Body Dynamics Algorithms, 2008,
//! ch. 2), generic over the scalar so the same code runs on `f64` and on dual numbers.
//!
//! - A motion vector is `[ω; v]`: angular velocity (rad/s) over the linear velocity (m/s) of the
//!   body point at the coordinate origin. A force vector is `[n; f]`: moment about the origin (N·m)
//!   over force (N).
//! - A Plücker transform `X = (E, r)` from frame A to frame B: `E` maps A-coordinates of a free
//!   vector to B-coordinates (`x_B = E·x_A`, so `E = Rᵀ` when `R`'s columns are B's axes in A) and
//!   `r` is B's origin in A-coordinates (m). On motion vectors `X·[ω; v] = [Eω; E(v − r×ω)]`; on
//!   force vectors `X*·[n; f] = [E(n − r×f); Ef]`; `Xᵀ` carries forces back from B to A.
//! - Cross products: `v ×m w = [ω×ω_w; ω×v_w + v×ω_w]`, `v ×f f = [ω×n + v×f; ω×f]`.
//! - A rigid-body inertia is (mass kg, centre of mass `c` m, rotational inertia about the centre
//!   of mass kg·m²); an articulated-body inertia is a general symmetric 6×6 block matrix
//!   `[A B; Bᵀ C]` mapping motion to force.

use std::ops::{Add, AddAssign, Neg, Sub};

use num_dual::DualNum;

/// The scalar type the dynamics run on: `f64` or a forward dual number over `f64`.
pub trait Real: DualNum<Primitive = f64> + Copy + Send + Sync {}
impl<T: DualNum<Primitive = f64> + Copy + Send + Sync> Real for T {}

/// The constant `v` as a scalar of type `T`.
#[inline]
pub fn c<T: Real>(v: f64) -> T {
    T::from(v)
}

/// A 3-vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Vec3<T>(pub [T; 3]);

/// A 3×3 matrix stored by rows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mat3<T>(pub [[T; 3]; 3]);

impl<T: Real> Vec3<T> {
    /// The zero vector.
    #[inline]
    pub fn zero() -> Self {
        Vec3([T::zero(); 3])
    }
    /// Lifts an `f64` vector.
    #[inline]
    pub fn from_f64(v: [f64; 3]) -> Self {
        Vec3(v.map(c))
    }
    /// Dot product.
    #[inline]
    pub fn dot(&self, o: &Self) -> T {
        self.0[0] * o.0[0] + self.0[1] * o.0[1] + self.0[2] * o.0[2]
    }
    /// Cross product `self × o`.
    #[inline]
    pub fn cross(&self, o: &Self) -> Self {
        let (a, b) = (&self.0, &o.0);
        Vec3([
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ])
    }
    /// Multiplies every component by `s`.
    #[inline]
    pub fn scale(&self, s: T) -> Self {
        let [x, y, z] = self.0;
        Vec3([x * s, y * s, z * s])
    }
    /// Real parts.
    #[inline]
    pub fn re(&self) -> [f64; 3] {
        self.0.map(|x| x.re())
    }
}

impl<T: Real> Add for Vec3<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Vec3([self.0[0] + o.0[0], self.0[1] + o.0[1], self.0[2] + o.0[2]])
    }
}
impl<T: Real> Sub for Vec3<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Vec3([self.0[0] - o.0[0], self.0[1] - o.0[1], self.0[2] - o.0[2]])
    }
}
impl<T: Real> Neg for Vec3<T> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        let [x, y, z] = self.0;
        Vec3([-x, -y, -z])
    }
}

impl<T: Real> Mat3<T> {
    /// The zero matrix.
    #[inline]
    pub fn zero() -> Self {
        Mat3([[T::zero(); 3]; 3])
    }
    /// The identity.
    #[inline]
    pub fn identity() -> Self {
        let mut m = Self::zero();
        for i in 0..3 {
            m.0[i][i] = T::one();
        }
        m
    }
    /// Lifts an `f64` matrix.
    #[inline]
    pub fn from_f64(m: [[f64; 3]; 3]) -> Self {
        Mat3(m.map(|r| r.map(c)))
    }
    /// `self · v`.
    #[inline]
    pub fn mul_vec(&self, v: &Vec3<T>) -> Vec3<T> {
        let m = &self.0;
        let row = |i: usize| m[i][0] * v.0[0] + m[i][1] * v.0[1] + m[i][2] * v.0[2];
        // Written out: `[0, 1, 2].map(...)` is not always inlined in the hot loops.
        Vec3([row(0), row(1), row(2)])
    }
    /// `selfᵀ · v`.
    #[inline]
    pub fn tr_mul_vec(&self, v: &Vec3<T>) -> Vec3<T> {
        let m = &self.0;
        let col = |i: usize| m[0][i] * v.0[0] + m[1][i] * v.0[1] + m[2][i] * v.0[2];
        Vec3([col(0), col(1), col(2)])
    }
    /// `self · o`.
    #[inline]
    pub fn mul_mat(&self, o: &Self) -> Self {
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] =
                    self.0[i][0] * o.0[0][j] + self.0[i][1] * o.0[1][j] + self.0[i][2] * o.0[2][j];
            }
        }
        r
    }
    /// The transpose.
    #[inline]
    pub fn transpose(&self) -> Self {
        let m = &self.0;
        let col = |i: usize| [m[0][i], m[1][i], m[2][i]];
        Mat3([col(0), col(1), col(2)])
    }
    /// The matrix `[v]×` with `[v]×·w = v × w`.
    #[inline]
    pub fn skew(v: &Vec3<T>) -> Self {
        let [x, y, z] = v.0;
        let o = T::zero();
        Mat3([[o, -z, y], [z, o, -x], [-y, x, o]])
    }
    /// Rotation by `angle` (rad) about the constant unit `axis` (Rodrigues):
    /// `R = cos·1 + sin·[a]× + (1 − cos)·aaᵀ`; columns are the rotated axes.
    #[inline]
    pub fn rotation(axis: [f64; 3], angle: T) -> Self {
        let (s, co) = angle.sin_cos();
        let omc = T::one() - co;
        let [x, y, z] = axis;
        let k = [[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]];
        let mut r = Self::zero();
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] = omc * (axis[i] * axis[j]) + s * k[i][j];
            }
            r.0[i][i] += co;
        }
        r
    }
    /// Rotation matrix of the unit quaternion `(w, x, y, z)`.
    #[inline]
    pub fn from_quaternion(q: [T; 4]) -> Self {
        let [w, x, y, z] = q;
        let two = c::<T>(2.0);
        let one = T::one();
        Mat3([
            [
                one - two * (y * y + z * z),
                two * (x * y - w * z),
                two * (x * z + w * y),
            ],
            [
                two * (x * y + w * z),
                one - two * (x * x + z * z),
                two * (y * z - w * x),
            ],
            [
                two * (x * z - w * y),
                two * (y * z + w * x),
                one - two * (x * x + y * y),
            ],
        ])
    }
    /// `[r]×·self`: the cross product of `r` with each column (18 multiplications, not 27).
    #[inline]
    pub fn skew_mul(r: &Vec3<T>, m: &Self) -> Self {
        let [x, y, z] = r.0;
        let m = &m.0;
        Mat3([0, 1, 2].map(|i| {
            [0, 1, 2].map(|j| match i {
                0 => y * m[2][j] - z * m[1][j],
                1 => z * m[0][j] - x * m[2][j],
                _ => x * m[1][j] - y * m[0][j],
            })
        }))
    }
    /// `self·[r]×`: row `i` is `rowᵢ × r`.
    #[inline]
    pub fn mul_skew(&self, r: &Vec3<T>) -> Self {
        let [x, y, z] = r.0;
        Mat3(self.0.map(|m| {
            [
                m[1] * z - m[2] * y,
                m[2] * x - m[0] * z,
                m[0] * y - m[1] * x,
            ]
        }))
    }
    /// Multiplies every entry by `s`.
    #[inline]
    pub fn scaled(&self, s: T) -> Self {
        Mat3(self.0.map(|r| r.map(|x| x * s)))
    }
}

impl<T: Real> Add for Mat3<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        let mut r = self;
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] += o.0[i][j];
            }
        }
        r
    }
}
impl<T: Real> Sub for Mat3<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        let mut r = self;
        for i in 0..3 {
            for j in 0..3 {
                r.0[i][j] -= o.0[i][j];
            }
        }
        r
    }
}

/// A spatial motion vector `[ω; v]` (rad/s; m/s) or acceleration (rad/s²; m/s²).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion<T> {
    /// Angular part.
    pub ang: Vec3<T>,
    /// Linear part (velocity of the body point at the origin).
    pub lin: Vec3<T>,
}

/// A spatial force vector `[n; f]` (N·m about the origin; N).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Force<T> {
    /// Moment about the origin.
    pub ang: Vec3<T>,
    /// Force.
    pub lin: Vec3<T>,
}

impl<T: Real> Motion<T> {
    /// The zero motion.
    #[inline]
    pub fn zero() -> Self {
        Motion {
            ang: Vec3::zero(),
            lin: Vec3::zero(),
        }
    }
    /// Component `k` of `[ω; v]` (0..6).
    #[inline]
    pub fn get(&self, k: usize) -> T {
        if k < 3 {
            self.ang.0[k]
        } else {
            self.lin.0[k - 3]
        }
    }
    /// The unit motion along component `k` of `[ω; v]`.
    #[inline]
    pub fn unit(k: usize) -> Self {
        let mut m = Self::zero();
        if k < 3 {
            m.ang.0[k] = T::one();
        } else {
            m.lin.0[k - 3] = T::one();
        }
        m
    }
    /// Multiplies by a scalar.
    #[inline]
    pub fn scale(&self, s: T) -> Self {
        Motion {
            ang: self.ang.scale(s),
            lin: self.lin.scale(s),
        }
    }
    /// Motion cross product `self ×m m`.
    #[inline]
    pub fn cross_motion(&self, m: &Motion<T>) -> Motion<T> {
        Motion {
            ang: self.ang.cross(&m.ang),
            lin: self.ang.cross(&m.lin) + self.lin.cross(&m.ang),
        }
    }
    /// Force cross product `self ×f f`.
    #[inline]
    pub fn cross_force(&self, f: &Force<T>) -> Force<T> {
        Force {
            ang: self.ang.cross(&f.ang) + self.lin.cross(&f.lin),
            lin: self.ang.cross(&f.lin),
        }
    }
    /// The power pairing `self · f` (W).
    #[inline]
    pub fn dot(&self, f: &Force<T>) -> T {
        self.ang.dot(&f.ang) + self.lin.dot(&f.lin)
    }
}

impl<T: Real> Add for Motion<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Motion {
            ang: self.ang + o.ang,
            lin: self.lin + o.lin,
        }
    }
}
impl<T: Real> AddAssign for Motion<T> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        for k in 0..3 {
            self.ang.0[k] += o.ang.0[k];
            self.lin.0[k] += o.lin.0[k];
        }
    }
}

impl<T: Real> Force<T> {
    /// The zero force.
    #[inline]
    pub fn zero() -> Self {
        Force {
            ang: Vec3::zero(),
            lin: Vec3::zero(),
        }
    }
    /// Component `k` of `[n; f]` (0..6).
    #[inline]
    pub fn get(&self, k: usize) -> T {
        if k < 3 {
            self.ang.0[k]
        } else {
            self.lin.0[k - 3]
        }
    }
    /// Multiplies by a scalar.
    #[inline]
    pub fn scale(&self, s: T) -> Self {
        Force {
            ang: self.ang.scale(s),
            lin: self.lin.scale(s),
        }
    }
    /// The spatial force of a pure force `f` (N) acting at point `p` (m), both in these
    /// coordinates.
    #[inline]
    pub fn at_point(p: &Vec3<T>, f: &Vec3<T>) -> Self {
        Force {
            ang: p.cross(f),
            lin: *f,
        }
    }
}

impl<T: Real> Add for Force<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        Force {
            ang: self.ang + o.ang,
            lin: self.lin + o.lin,
        }
    }
}
impl<T: Real> Sub for Force<T> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        Force {
            ang: self.ang - o.ang,
            lin: self.lin - o.lin,
        }
    }
}
impl<T: Real> AddAssign for Force<T> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        for k in 0..3 {
            self.ang.0[k] += o.ang.0[k];
            self.lin.0[k] += o.lin.0[k];
        }
    }
}

/// A Plücker coordinate transform from frame A to frame B (see the module header).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xform<T> {
    /// Rotation taking A-coordinates to B-coordinates.
    pub e: Mat3<T>,
    /// B's origin in A-coordinates (m).
    pub r: Vec3<T>,
}

impl<T: Real> Xform<T> {
    /// The identity transform.
    #[inline]
    pub fn identity() -> Self {
        Xform {
            e: Mat3::identity(),
            r: Vec3::zero(),
        }
    }
    /// A pure translation: B's origin at `r` in A, axes parallel.
    #[inline]
    pub fn translation(r: Vec3<T>) -> Self {
        Xform {
            e: Mat3::identity(),
            r,
        }
    }
    /// `X·m` for a motion vector given in A-coordinates.
    #[inline]
    pub fn apply_motion(&self, m: &Motion<T>) -> Motion<T> {
        Motion {
            ang: self.e.mul_vec(&m.ang),
            lin: self.e.mul_vec(&(m.lin - self.r.cross(&m.ang))),
        }
    }
    /// `X⁻¹·m` for a motion vector given in B-coordinates.
    #[inline]
    pub fn inv_apply_motion(&self, m: &Motion<T>) -> Motion<T> {
        let ang = self.e.tr_mul_vec(&m.ang);
        Motion {
            ang,
            lin: self.e.tr_mul_vec(&m.lin) + self.r.cross(&ang),
        }
    }
    /// `X*·f` for a force vector given in A-coordinates.
    #[inline]
    pub fn apply_force(&self, f: &Force<T>) -> Force<T> {
        Force {
            ang: self.e.mul_vec(&(f.ang - self.r.cross(&f.lin))),
            lin: self.e.mul_vec(&f.lin),
        }
    }
    /// `Xᵀ·f`: a force vector in B-coordinates carried back to A-coordinates.
    #[inline]
    pub fn tr_apply_force(&self, f: &Force<T>) -> Force<T> {
        let lin = self.e.tr_mul_vec(&f.lin);
        Force {
            ang: self.e.tr_mul_vec(&f.ang) + self.r.cross(&lin),
            lin,
        }
    }
    /// The composition `self · inner` (first `inner`: A→B, then `self`: B→C).
    #[inline]
    pub fn compose(&self, inner: &Xform<T>) -> Xform<T> {
        Xform {
            e: self.e.mul_mat(&inner.e),
            r: inner.r + inner.e.tr_mul_vec(&self.r),
        }
    }
    /// A point given in B-coordinates expressed in A-coordinates (m).
    #[inline]
    pub fn point_to_a(&self, p: &Vec3<T>) -> Vec3<T> {
        self.r + self.e.tr_mul_vec(p)
    }
}

/// A rigid body's spatial inertia about its own frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigidInertia<T> {
    /// Mass (kg).
    pub mass: T,
    /// Centre of mass in body coordinates (m).
    pub com: Vec3<T>,
    /// Rotational inertia about the centre of mass, body axes (kg·m²).
    pub inertia_com: Mat3<T>,
}

impl<T: Real> RigidInertia<T> {
    /// `I·v`: the momentum of the body moving with spatial velocity `v`.
    #[inline]
    pub fn mul_motion(&self, v: &Motion<T>) -> Force<T> {
        // Linear momentum m·(v − c×ω); angular momentum about the origin I_c·ω + c×h.
        let h = (v.lin - self.com.cross(&v.ang)).scale(self.mass);
        Force {
            ang: self.inertia_com.mul_vec(&v.ang) + self.com.cross(&h),
            lin: h,
        }
    }
    /// The same inertia as a general 6×6 articulated-body inertia.
    #[inline]
    pub fn to_articulated(&self) -> ArticulatedInertia<T> {
        let cx = Mat3::skew(&self.com);
        let mcx = cx.scaled(self.mass);
        // [I_c − m·[c]×[c]×,  m[c]×;  −m[c]×,  m·1]   ([c]×ᵀ = −[c]×)
        ArticulatedInertia {
            a: self.inertia_com - mcx.mul_mat(&cx),
            b: mcx,
            c: Mat3::identity().scaled(self.mass),
        }
    }
}

/// A symmetric 6×6 inertia `[A B; Bᵀ C]` mapping motion to force (articulated-body inertia).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArticulatedInertia<T> {
    /// Angular–angular block (symmetric), kg·m².
    pub a: Mat3<T>,
    /// Angular–linear block, kg·m.
    pub b: Mat3<T>,
    /// Linear–linear block (symmetric), kg.
    pub c: Mat3<T>,
}

impl<T: Real> ArticulatedInertia<T> {
    /// The zero inertia.
    #[inline]
    pub fn zero() -> Self {
        ArticulatedInertia {
            a: Mat3::zero(),
            b: Mat3::zero(),
            c: Mat3::zero(),
        }
    }
    /// `I·v`.
    #[inline]
    pub fn mul_motion(&self, v: &Motion<T>) -> Force<T> {
        Force {
            ang: self.a.mul_vec(&v.ang) + self.b.mul_vec(&v.lin),
            lin: self.b.tr_mul_vec(&v.ang) + self.c.mul_vec(&v.lin),
        }
    }
    /// `Xᵀ·I·X`: an inertia given in B-coordinates expressed in A-coordinates (`X`: A→B).
    #[inline]
    pub fn transform_back(&self, x: &Xform<T>) -> Self {
        let e = &x.e;
        let et = e.transpose();
        // Rotate: diag(E,E)ᵀ · I · diag(E,E).
        let a = et.mul_mat(&self.a).mul_mat(e);
        let b = et.mul_mat(&self.b).mul_mat(e);
        let cc = et.mul_mat(&self.c).mul_mat(e);
        // Translate with X_t = [1 0; −[r]× 1]: [A + [r]×Bᵀ − (B + [r]×C)[r]×,  B + [r]×C;  ·,  C].
        let b2 = b + Mat3::skew_mul(&x.r, &cc);
        let a2 = a + Mat3::skew_mul(&x.r, &b.transpose()) - b2.mul_skew(&x.r);
        ArticulatedInertia {
            a: a2,
            b: b2,
            c: cc,
        }
    }
    /// `self − u·uᵀ·s` for a force vector `u` and scalar `s` (a rank-one update).
    #[inline]
    pub fn sub_outer(&self, u: &Force<T>, s: T) -> Self {
        let mut r = *self;
        for i in 0..3 {
            for j in 0..3 {
                r.a.0[i][j] -= u.ang.0[i] * u.ang.0[j] * s;
                r.b.0[i][j] -= u.ang.0[i] * u.lin.0[j] * s;
                r.c.0[i][j] -= u.lin.0[i] * u.lin.0[j] * s;
            }
        }
        r
    }
    /// `self − Σᵢⱼ uᵢ·Wᵢⱼ·uⱼᵀ` for force vectors `u` and a symmetric weight matrix `w`
    /// (its leading `u.len()` square block).
    #[inline]
    pub fn sub_weighted(&self, u: &[Force<T>], w: &[[T; 6]; 6]) -> Self {
        let mut r = *self;
        for (i, ui) in u.iter().enumerate() {
            for (j, uj) in u.iter().enumerate() {
                let s = w[i][j];
                for p in 0..3 {
                    for q in 0..3 {
                        r.a.0[p][q] -= ui.ang.0[p] * uj.ang.0[q] * s;
                        r.b.0[p][q] -= ui.ang.0[p] * uj.lin.0[q] * s;
                        r.c.0[p][q] -= ui.lin.0[p] * uj.lin.0[q] * s;
                    }
                }
            }
        }
        r
    }
}

impl<T: Real> Add for ArticulatedInertia<T> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        ArticulatedInertia {
            a: self.a + o.a,
            b: self.b + o.b,
            c: self.c + o.c,
        }
    }
}
impl<T: Real> AddAssign for ArticulatedInertia<T> {
    #[inline]
    fn add_assign(&mut self, o: Self) {
        for i in 0..3 {
            for j in 0..3 {
                self.a.0[i][j] += o.a.0[i][j];
                self.b.0[i][j] += o.b.0[i][j];
                self.c.0[i][j] += o.c.0[i][j];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Matrix6, Vector6};
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn rv(rng: &mut ChaCha8Rng) -> Vec3<f64> {
        Vec3([0; 3].map(|_| rng.random_range(-1.0..1.0)))
    }
    fn m3(m: &Mat3<f64>) -> Matrix3<f64> {
        Matrix3::from_fn(|i, j| m.0[i][j])
    }
    fn skew(v: &Vec3<f64>) -> Matrix3<f64> {
        m3(&Mat3::skew(v))
    }
    /// Featherstone's 6×6 motion transform `[E 0; −E[r]× E]`.
    fn x6(x: &Xform<f64>) -> Matrix6<f64> {
        let e = m3(&x.e);
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&e);
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&e);
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-e * skew(&x.r)));
        m
    }
    fn mv(m: &Motion<f64>) -> Vector6<f64> {
        Vector6::from_fn(|k, _| m.get(k))
    }
    fn fv(f: &Force<f64>) -> Vector6<f64> {
        Vector6::from_fn(|k, _| f.get(k))
    }
    fn random_xform(rng: &mut ChaCha8Rng) -> Xform<f64> {
        let mut axis = rv(rng);
        axis = axis.scale(1.0 / axis.dot(&axis).sqrt());
        Xform {
            e: Mat3::rotation(axis.0, rng.random_range(-3.0..3.0)),
            r: rv(rng),
        }
    }
    fn i6(a: &ArticulatedInertia<f64>) -> Matrix6<f64> {
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&m3(&a.a));
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&m3(&a.b));
        m.fixed_view_mut::<3, 3>(3, 0)
            .copy_from(&m3(&a.b).transpose());
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&m3(&a.c));
        m
    }

    #[test]
    fn transforms_agree_with_six_by_six_matrices() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for _ in 0..20 {
            let x = random_xform(&mut rng);
            let y = random_xform(&mut rng);
            let m = Motion {
                ang: rv(&mut rng),
                lin: rv(&mut rng),
            };
            let f = Force {
                ang: rv(&mut rng),
                lin: rv(&mut rng),
            };
            let xm = x6(&x);
            let xf = xm.try_inverse().unwrap().transpose();
            assert!((mv(&x.apply_motion(&m)) - xm * mv(&m)).norm() < 1e-12);
            assert!(
                (mv(&x.inv_apply_motion(&m)) - xm.try_inverse().unwrap() * mv(&m)).norm() < 1e-12
            );
            assert!((fv(&x.apply_force(&f)) - xf * fv(&f)).norm() < 1e-12);
            assert!((fv(&x.tr_apply_force(&f)) - xm.transpose() * fv(&f)).norm() < 1e-12);
            assert!((x6(&y.compose(&x)) - x6(&y) * xm).norm() < 1e-12);
            // Power is invariant: (Xm)·(X*f) = m·f.
            assert!((x.apply_motion(&m).dot(&x.apply_force(&f)) - m.dot(&f)).abs() < 1e-12);
        }
    }

    #[test]
    fn inertia_and_cross_products_agree_with_matrices() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let x = random_xform(&mut rng);
        let l = Mat3([[0.3, 0.0, 0.0], [0.1, 0.2, 0.0], [-0.1, 0.05, 0.4]]);
        let body = RigidInertia {
            mass: 1.7,
            com: rv(&mut rng),
            inertia_com: l.mul_mat(&l.transpose()),
        };
        let v = Motion {
            ang: rv(&mut rng),
            lin: rv(&mut rng),
        };
        let w = Motion {
            ang: rv(&mut rng),
            lin: rv(&mut rng),
        };
        let f = Force {
            ang: rv(&mut rng),
            lin: rv(&mut rng),
        };
        let ia = body.to_articulated();
        let (r, mm) = (rv(&mut rng), l.mul_mat(&Mat3::skew(&rv(&mut rng))));
        assert!((m3(&Mat3::skew_mul(&r, &mm)) - skew(&r) * m3(&mm)).norm() < 1e-14);
        assert!((m3(&mm.mul_skew(&r)) - m3(&mm) * skew(&r)).norm() < 1e-14);
        assert!((fv(&body.mul_motion(&v)) - i6(&ia) * mv(&v)).norm() < 1e-12);
        assert!((fv(&ia.mul_motion(&v)) - i6(&ia) * mv(&v)).norm() < 1e-12);
        let xm = x6(&x);
        assert!((i6(&ia.transform_back(&x)) - xm.transpose() * i6(&ia) * xm).norm() < 1e-12);
        // crm(v) = [[ω]× 0; [v]× [ω]×], crf(v) = −crm(v)ᵀ.
        let mut crm = Matrix6::zeros();
        crm.fixed_view_mut::<3, 3>(0, 0).copy_from(&skew(&v.ang));
        crm.fixed_view_mut::<3, 3>(3, 3).copy_from(&skew(&v.ang));
        crm.fixed_view_mut::<3, 3>(3, 0).copy_from(&skew(&v.lin));
        assert!((mv(&v.cross_motion(&w)) - crm * mv(&w)).norm() < 1e-12);
        assert!((fv(&v.cross_force(&f)) - (-crm.transpose()) * fv(&f)).norm() < 1e-12);
        // Kinetic energy ½vᵀIv equals ½m|v_c|² + ½ωᵀI_cω.
        let vc = v.lin - body.com.cross(&v.ang);
        let ke = 0.5 * body.mass * vc.dot(&vc) + 0.5 * v.ang.dot(&body.inertia_com.mul_vec(&v.ang));
        assert!((0.5 * v.dot(&body.mul_motion(&v)) - ke).abs() < 1e-12);
    }

    #[test]
    fn quaternion_and_rodrigues_rotations_agree() {
        let axis = [0.0, 0.6, 0.8];
        let angle: f64 = 1.1;
        let (s, co) = (0.5 * angle).sin_cos();
        let q = [co, 0.0, 0.6 * s, 0.8 * s];
        let a = Mat3::from_quaternion(q);
        let b = Mat3::rotation(axis, angle);
        assert!((m3(&a) - m3(&b)).norm() < 1e-14);
        assert!((m3(&a) * m3(&a).transpose() - Matrix3::identity()).norm() < 1e-14);
    }
}
