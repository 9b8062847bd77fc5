//! The articulated character as the dynamics see it: a tree of rigid links, each attached to its
//! parent (or to the world) by one joint, plus actuators, passive joint elements and contact
//! points. Built from a problem file by [`crate::gait::spec`], or directly in tests.
//!
//! Conventions (SI units throughout; y is up):
//! - Links are ordered so that a parent precedes its children; link 0 is the root.
//! - Link `i`'s frame sits at its joint: at zero joint coordinates it is its parent's frame
//!   translated by `origin` (m, parent coordinates); the joint then moves it. Hence the
//!   parent-to-link transform is `X_J(q_i)·X_T(origin)`.
//! - Generalized coordinates `q` (length `nq`) and velocities `v` (length `nv`) are the links'
//!   joint coordinates concatenated in link order. Only the floating joint has `nq ≠ nv`.
//! - Joint velocities and motion subspaces are in link coordinates and constant, so the
//!   velocity-product term `c_J` vanishes for every joint kind (Featherstone 2008, table 4.1):
//!   - revolute about unit `axis`: `q` = angle (rad), `S = [axis; 0]`;
//!   - prismatic along unit `axis`: `q` = displacement (m), `S = [0; axis]`;
//!   - planar (root only, the xy plane): `q = (x, y, θ)` (m, m, rad) in the world,
//!     `v = (ω_z, v_x, v_y)` in link coordinates, `S = [e_z;0 | 0;e_x | 0;e_y]`,
//!     `ẋ = cosθ·v_x − sinθ·v_y`, `ẏ = sinθ·v_x + cosθ·v_y`, `θ̇ = ω_z`;
//!   - floating (root only): `q = (p, w, x, y, z)` position (m) and unit quaternion of the link's
//!     orientation, `v = (ω, v)` the link's spatial velocity in link coordinates, `S = 1₆`,
//!     `ṗ = R·v`, `q̇uat = ½·quat ⊗ (0, ω)`.

use super::spatial::{Mat3, Motion, Real, RigidInertia, Vec3, Xform};

/// How a link is attached to its parent.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum JointKind {
    /// One rotation (rad) about a unit axis in the parent's frame.
    Revolute {
        /// Unit axis.
        axis: [f64; 3],
    },
    /// One translation (m) along a unit axis in the parent's frame.
    Prismatic {
        /// Unit axis.
        axis: [f64; 3],
    },
    /// Translation in x, y and rotation about z relative to the world (root link only).
    Planar,
    /// Six degrees of freedom relative to the world (root link only).
    Floating,
}

impl JointKind {
    /// Number of position coordinates.
    pub fn nq(&self) -> usize {
        match self {
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => 1,
            JointKind::Planar => 3,
            JointKind::Floating => 7,
        }
    }

    /// Number of velocity coordinates.
    pub fn nv(&self) -> usize {
        match self {
            JointKind::Floating => 6,
            k => k.nq(),
        }
    }

    /// Column `k` of the motion subspace `S` (link coordinates).
    pub fn subspace<T: Real>(&self, k: usize) -> Motion<T> {
        match self {
            JointKind::Revolute { axis } => Motion {
                ang: Vec3::from_f64(*axis),
                lin: Vec3::zero(),
            },
            JointKind::Prismatic { axis } => Motion {
                ang: Vec3::zero(),
                lin: Vec3::from_f64(*axis),
            },
            JointKind::Planar => Motion::unit([2, 3, 4][k]),
            JointKind::Floating => Motion::unit(k),
        }
    }

    /// The joint transform `X_J(q)` from the joint frame to the link frame.
    pub fn transform<T: Real>(&self, q: &[T]) -> Xform<T> {
        match self {
            JointKind::Revolute { axis } => Xform {
                e: Mat3::rotation(*axis, q[0]).transpose(),
                r: Vec3::zero(),
            },
            JointKind::Prismatic { axis } => Xform::translation(Vec3::from_f64(*axis).scale(q[0])),
            JointKind::Planar => Xform {
                e: Mat3::rotation([0.0, 0.0, 1.0], q[2]).transpose(),
                r: Vec3([q[0], q[1], T::zero()]),
            },
            JointKind::Floating => Xform {
                e: Mat3::from_quaternion([q[3], q[4], q[5], q[6]]).transpose(),
                r: Vec3([q[0], q[1], q[2]]),
            },
        }
    }

    /// Position-coordinate rates `q̇` from velocities `v` (the kinematic map above).
    pub fn qdot<T: Real>(&self, q: &[T], v: &[T], qd: &mut [T]) {
        match self {
            JointKind::Revolute { .. } | JointKind::Prismatic { .. } => qd[0] = v[0],
            JointKind::Planar => {
                let (s, co) = q[2].sin_cos();
                qd[0] = co * v[1] - s * v[2];
                qd[1] = s * v[1] + co * v[2];
                qd[2] = v[0];
            }
            JointKind::Floating => {
                let r = Mat3::from_quaternion([q[3], q[4], q[5], q[6]]);
                let pd = r.mul_vec(&Vec3([v[3], v[4], v[5]]));
                qd[..3].copy_from_slice(&pd.0);
                let [w, x, y, z] = [q[3], q[4], q[5], q[6]];
                let [a, b, cc] = [v[0], v[1], v[2]];
                let h = T::from(0.5);
                qd[3] = h * (-x * a - y * b - z * cc);
                qd[4] = h * (w * a + y * cc - z * b);
                qd[5] = h * (w * b + z * a - x * cc);
                qd[6] = h * (w * cc + x * b - y * a);
            }
        }
    }

    /// Restores invariants after an integration step (unit quaternion).
    pub fn normalize<T: Real>(&self, q: &mut [T]) {
        if let JointKind::Floating = self {
            let n = (q[3] * q[3] + q[4] * q[4] + q[5] * q[5] + q[6] * q[6]).sqrt();
            for x in &mut q[3..7] {
                *x /= n;
            }
        }
    }

    /// Whether the joint has a single coordinate (springs, limits and actuators apply).
    pub fn is_scalar(&self) -> bool {
        self.nv() == 1
    }
}

/// A linear spring and damper acting on a scalar joint: `τ = −k·(q − rest) − d·q̇`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spring {
    /// Stiffness (N·m/rad or N/m).
    pub stiffness: f64,
    /// Rest coordinate (rad or m).
    pub rest: f64,
    /// Damping (N·m·s/rad or N·s/m).
    pub damping: f64,
}

/// Joint limits enforced by stiff smooth one-sided springs (see [`Limits::torque`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Lower limit (rad or m).
    pub lower: f64,
    /// Upper limit (rad or m).
    pub upper: f64,
    /// Stiffness of the limit spring beyond the limit (N·m/rad or N/m).
    pub stiffness: f64,
    /// Smoothing width (rad or m): the spring force is `k·w·softplus(d/w)` for penetration `d`.
    pub width: f64,
}

impl Limits {
    /// Generalized force of the limit springs at coordinate `q`:
    /// `k·w·(softplus((lower − q)/w) − softplus((q − upper)/w))`, with
    /// `softplus(x) = ln(1 + eˣ)`. It is smooth, tends to the linear spring `k·d` for penetration
    /// `d ≫ w` and to zero inside the range (at most `k·w·e^(−gap/w)`).
    pub fn torque<T: Real>(&self, q: T) -> T {
        let w = self.width;
        let below = softplus((T::from(self.lower) - q) / w);
        let above = softplus((q - self.upper) / w);
        (below - above) * (self.stiffness * w)
    }
}

/// `ln(1 + eˣ)` evaluated without overflow.
pub fn softplus<T: Real>(x: T) -> T {
    if x.re() > 0.0 {
        x + (-x).exp().ln_1p()
    } else {
        x.exp().ln_1p()
    }
}

/// Display geometry of a link (link coordinates, m); export only.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// Box with full side lengths, centred at `center`.
    Box {
        /// Side lengths (m).
        size: [f64; 3],
        /// Centre (m).
        center: [f64; 3],
    },
    /// Capsule (or cylinder) between two points.
    Capsule {
        /// Radius (m).
        radius: f64,
        /// End points (m).
        from: [f64; 3],
        /// End points (m).
        to: [f64; 3],
    },
    /// Sphere.
    Sphere {
        /// Radius (m).
        radius: f64,
        /// Centre (m).
        center: [f64; 3],
    },
    /// Right circular cone from its apex to the centre of its flat base.
    Cone {
        /// Base radius (m).
        radius: f64,
        /// Apex (m).
        apex: [f64; 3],
        /// Centre of the base (m).
        base: [f64; 3],
    },
}

/// One rigid link and the joint attaching it to its parent.
#[derive(Debug, Clone, PartialEq)]
pub struct Link {
    /// Name from the problem file.
    pub name: String,
    /// Parent link, `None` for the root (attached to the world).
    pub parent: Option<usize>,
    /// The joint.
    pub joint: JointKind,
    /// Joint frame origin in the parent's frame (m).
    pub origin: [f64; 3],
    /// Mass properties (kg, m, kg·m²).
    pub inertia: RigidInertia<f64>,
    /// Passive spring-damper on a scalar joint.
    pub spring: Option<Spring>,
    /// Limits of a scalar joint.
    pub limits: Option<Limits>,
    /// Display shape.
    pub shape: Shape,
    /// Contact points in link coordinates (m).
    pub contacts: Vec<[f64; 3]>,
    /// Offset of this joint's coordinates in `q`.
    pub q_index: usize,
    /// Offset of this joint's velocities in `v`.
    pub v_index: usize,
}

/// An actuator: a bounded generalized force on one scalar joint, either commanded directly
/// (its control is the force) or by a position servo (its control is a set-point offset).
#[derive(Debug, Clone, PartialEq)]
pub struct Actuator {
    /// Name.
    pub name: String,
    /// The link whose joint it drives.
    pub link: usize,
    /// Lower and upper force bounds (N·m or N).
    pub bounds: [f64; 2],
    /// Position servo: the control is the set-point offset and the force follows the joint.
    pub servo: Option<Servo>,
}

/// A position servo on a scalar joint with coordinate `q` and rate `q̇`: for control `u` (the
/// set-point's offset from `rest`, rad or m) the actuator force is
/// ```text
///   τ = sat(e),  e = kp·(rest + u − q) − kd·q̇,
///   sat(e) = mid + half·tanh((e − mid)/half),  mid, half = centre and half-width of the bounds
/// ```
/// so `τ` never leaves the actuator's bounds, `sat(e) ≈ e` for small `e − mid`, and
/// `sat′(e) = 1 − tanh²((e − mid)/half) ∈ (0, 1]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Servo {
    /// Proportional gain kp (N·m/rad or N/m).
    pub stiffness: f64,
    /// Rate gain kd (N·m·s/rad or N·s/m).
    pub damping: f64,
    /// Set point at zero control (rad or m): the joint's coordinate in the file's initial state.
    pub rest: f64,
    /// Range of the control `u` (rad or m): the joint's limits less `rest`.
    pub offsets: [f64; 2],
}

/// An actuator's force and its partial derivatives at one state (see [`Servo`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForcePartials {
    /// Force (N·m or N).
    pub force: f64,
    /// `∂τ/∂u`.
    pub d_control: f64,
    /// `∂τ/∂q` of the driven joint's coordinate.
    pub d_position: f64,
    /// `∂τ/∂q̇` of the driven joint's rate.
    pub d_rate: f64,
}

impl Actuator {
    /// Range `[lower, upper]` of the control: the force bounds (N·m or N), or for a servo the
    /// set-point offsets (rad or m).
    pub fn control_range(&self) -> [f64; 2] {
        self.servo.map_or(self.bounds, |s| s.offsets)
    }

    /// The force for control `u` at joint coordinate `q` and rate `qd` (see [`Servo`]).
    pub fn force<T: Real>(&self, u: T, q: T, qd: T) -> T {
        match &self.servo {
            None => u,
            Some(s) => {
                let (mid, half) = self.saturation();
                let e = (u + s.rest - q) * s.stiffness - qd * s.damping;
                ((e - mid) / half).tanh() * half + mid
            }
        }
    }

    /// [`Actuator::force`] and its partial derivatives.
    pub fn force_partials(&self, u: f64, q: f64, qd: f64) -> ForcePartials {
        match &self.servo {
            None => ForcePartials {
                force: u,
                d_control: 1.0,
                d_position: 0.0,
                d_rate: 0.0,
            },
            Some(s) => {
                let (mid, half) = self.saturation();
                let e = s.stiffness * (u + s.rest - q) - s.damping * qd;
                let th = ((e - mid) / half).tanh();
                let slope = 1.0 - th * th;
                ForcePartials {
                    force: mid + half * th,
                    d_control: slope * s.stiffness,
                    d_position: -slope * s.stiffness,
                    d_rate: -slope * s.damping,
                }
            }
        }
    }

    /// Centre and half-width of the force bounds.
    fn saturation(&self) -> (f64, f64) {
        let [lo, hi] = self.bounds;
        (0.5 * (lo + hi), 0.5 * (hi - lo))
    }
}

/// The ground contact law's constants (seed eq. 3.26–3.27 plus friction); see
/// [`crate::gait::contact`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactParams {
    /// Spring force scale (N); seed 0.5336.
    pub spring_force: f64,
    /// Spring exponential rate (1/m); seed 700.
    pub spring_rate: f64,
    /// Spring offset y₀ (m); seed 0.0035423.
    pub spring_offset: f64,
    /// Damping coefficient (N·s/m); seed 1000.
    pub damping: f64,
    /// Damping switch rate (1/m); seed 200.
    pub damping_rate: f64,
    /// Damping switch factor; seed 10.
    pub damping_factor: f64,
    /// Damping switch offset g₀ (m); seed 0.005.
    pub damping_offset: f64,
    /// Coulomb friction coefficient μ.
    pub friction: f64,
    /// Regularization speed of friction (m/s): full Coulomb force beyond a few times this slip.
    pub slip_speed: f64,
    /// Height of the ground plane (m).
    pub ground: f64,
}

impl Default for ContactParams {
    /// The seed's constants (eq. 3.26–3.27), μ = 0.8, slip speed 0.01 m/s, ground at y = 0.
    fn default() -> Self {
        ContactParams {
            spring_force: 0.5336,
            spring_rate: 700.0,
            spring_offset: 0.0035423,
            damping: 1000.0,
            damping_rate: 200.0,
            damping_factor: 10.0,
            damping_offset: 0.005,
            friction: 0.8,
            slip_speed: 0.01,
            ground: 0.0,
        }
    }
}

/// A whole character: links, actuators, contact law and gravity.
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    /// Links, parents first.
    pub links: Vec<Link>,
    /// Actuators.
    pub actuators: Vec<Actuator>,
    /// Gravity acceleration in the world (m/s²), e.g. `[0, −9.81, 0]`.
    pub gravity: [f64; 3],
    /// Ground contact constants.
    pub contact: ContactParams,
    /// Total number of position coordinates.
    pub nq: usize,
    /// Total number of velocity coordinates.
    pub nv: usize,
}

impl Model {
    /// Assembles a model, assigning coordinate offsets in link order. Links must list parents
    /// first (checked by the loader).
    pub fn new(
        mut links: Vec<Link>,
        actuators: Vec<Actuator>,
        gravity: [f64; 3],
        contact: ContactParams,
    ) -> Self {
        let (mut nq, mut nv) = (0, 0);
        for l in &mut links {
            l.q_index = nq;
            l.v_index = nv;
            nq += l.joint.nq();
            nv += l.joint.nv();
        }
        Model {
            links,
            actuators,
            gravity,
            contact,
            nq,
            nv,
        }
    }

    /// Total mass (kg).
    pub fn mass(&self) -> f64 {
        self.links.iter().map(|l| l.inertia.mass).sum()
    }

    /// `q̇` from `q` and `v` for the whole character.
    pub fn qdot<T: Real>(&self, q: &[T], v: &[T], qd: &mut [T]) {
        for l in &self.links {
            let (a, b) = (l.q_index, l.v_index);
            let (nq, nv) = (l.joint.nq(), l.joint.nv());
            l.joint
                .qdot(&q[a..a + nq], &v[b..b + nv], &mut qd[a..a + nq]);
        }
    }

    /// Restores the unit quaternion of a floating base.
    pub fn normalize<T: Real>(&self, q: &mut [T]) {
        for l in &self.links {
            let a = l.q_index;
            l.joint.normalize(&mut q[a..a + l.joint.nq()]);
        }
    }

    /// The neutral configuration: zero joint coordinates, identity orientation.
    pub fn neutral(&self) -> Vec<f64> {
        let mut q = vec![0.0; self.nq];
        for l in &self.links {
            if let JointKind::Floating = l.joint {
                q[l.q_index + 3] = 1.0;
            }
        }
        q
    }

    /// Parent-to-link transforms `X_J(q)·X_T` of every link.
    pub fn parent_transforms<T: Real>(&self, q: &[T], out: &mut Vec<Xform<T>>) {
        out.clear();
        for l in &self.links {
            let xt = Xform::translation(Vec3::from_f64(l.origin));
            let xj = l.joint.transform(&q[l.q_index..l.q_index + l.joint.nq()]);
            out.push(xj.compose(&xt));
        }
    }

    /// World-to-link transforms from parent-to-link transforms.
    pub fn world_transforms<T: Real>(&self, up: &[Xform<T>], out: &mut Vec<Xform<T>>) {
        out.clear();
        for (i, l) in self.links.iter().enumerate() {
            let x = match l.parent {
                None => up[i],
                Some(p) => up[i].compose(&out[p]),
            };
            out.push(x);
        }
    }

    /// Whether an actuator is a position servo: the controls are then set points and the effort
    /// `∫Σ τ² dt` depends on the motion.
    pub fn has_servos(&self) -> bool {
        self.actuators.iter().any(|a| a.servo.is_some())
    }

    /// Actuator forces for controls `u` (one per actuator) at state `(q, v)`, added into `tau`
    /// (length nv); returns `Σ τ²` (N²·m² or N²).
    pub fn add_actuators<T: Real>(&self, u: &[T], q: &[T], v: &[T], tau: &mut [T]) -> T {
        let mut square = T::zero();
        for (a, ua) in self.actuators.iter().zip(u) {
            let l = &self.links[a.link];
            let f = a.force(*ua, q[l.q_index], v[l.v_index]);
            tau[l.v_index] += f;
            square += f * f;
        }
        square
    }

    /// Passive generalized forces of springs, dampers and limits, added into `tau` (length nv).
    pub fn add_passive<T: Real>(&self, q: &[T], v: &[T], tau: &mut [T]) {
        for l in &self.links {
            if !l.joint.is_scalar() {
                continue;
            }
            let (qi, vi) = (q[l.q_index], v[l.v_index]);
            if let Some(s) = l.spring {
                tau[l.v_index] -= (qi - s.rest) * s.stiffness + vi * s.damping;
            }
            if let Some(lim) = l.limits {
                tau[l.v_index] += lim.torque(qi);
            }
        }
    }

    /// Potential energy of the passive springs (J). Limit springs are excluded: their potential
    /// `∫softplus` is a dilogarithm, and energy checks use characters without limits.
    pub fn passive_energy(&self, q: &[f64]) -> f64 {
        let mut e = 0.0;
        for l in &self.links {
            if !l.joint.is_scalar() {
                continue;
            }
            let qi = q[l.q_index];
            if let Some(s) = l.spring {
                e += 0.5 * s.stiffness * (qi - s.rest).powi(2);
            }
        }
        e
    }
}

/// Rotational inertia about the centre of mass of a uniform solid shape of mass `m` (kg·m²),
/// in link axes; capsules are treated as solid cylinders of the capsule's full length. A solid
/// cone of base radius `r` and height `h` about its centroid: `3/10·m·r²` about its axis,
/// `3/80·m·(4r² + h²)` across it.
pub fn shape_inertia(shape: &Shape, m: f64) -> [[f64; 3]; 3] {
    match shape {
        Shape::Box {
            size: [a, b, cc], ..
        } => diag([
            m * (b * b + cc * cc) / 12.0,
            m * (a * a + cc * cc) / 12.0,
            m * (a * a + b * b) / 12.0,
        ]),
        Shape::Sphere { radius, .. } => diag([0.4 * m * radius * radius; 3]),
        Shape::Capsule { radius, from, to } => {
            let len = distance(from, to);
            let along = 0.5 * m * radius * radius;
            let across = m * (3.0 * radius * radius + len * len) / 12.0;
            axial_inertia(from, to, along, across)
        }
        Shape::Cone { radius, apex, base } => {
            let h = distance(apex, base);
            let along = 0.3 * m * radius * radius;
            let across = 3.0 * m * (4.0 * radius * radius + h * h) / 80.0;
            axial_inertia(apex, base, along, across)
        }
    }
}

fn distance(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|k| (b[k] - a[k]).powi(2)).sum::<f64>().sqrt()
}

/// `I = across·1 + (along − across)·uuᵀ` with `u` the unit axis from `a` to `b` (y when they
/// coincide): a body of revolution's inertia with moments `along` and `across` its axis.
fn axial_inertia(a: &[f64; 3], b: &[f64; 3], along: f64, across: f64) -> [[f64; 3]; 3] {
    let len = distance(a, b);
    let u = if len > 0.0 {
        [0, 1, 2].map(|k| (b[k] - a[k]) / len)
    } else {
        [0.0, 1.0, 0.0]
    };
    let mut i = diag([across; 3]);
    for r in 0..3 {
        for s in 0..3 {
            i[r][s] += (along - across) * u[r] * u[s];
        }
    }
    i
}

/// The centre of a shape (m, link coordinates).
pub fn shape_center(shape: &Shape) -> [f64; 3] {
    match shape {
        Shape::Box { center, .. } | Shape::Sphere { center, .. } => *center,
        Shape::Capsule { from, to, .. } => [0, 1, 2].map(|k| 0.5 * (from[k] + to[k])),
        // The centroid, a quarter of the height up from the base.
        Shape::Cone { apex, base, .. } => [0, 1, 2].map(|k| 0.25 * apex[k] + 0.75 * base[k]),
    }
}

fn diag(d: [f64; 3]) -> [[f64; 3]; 3] {
    [[d[0], 0.0, 0.0], [0.0, d[1], 0.0], [0.0, 0.0, d[2]]]
}
