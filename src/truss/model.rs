//! The truss model: pin joints, beams between them, and the problem-level settings that turn a
//! structure into an optimization problem (seed §4.2).
//!
//! Units: positions in metres, forces in newtons, masses in kilograms. y is up.
//! Joint kinds (seed §4.2): anchors are joined to the earth (pinned: reactions in every direction;
//! roller: reactions only along given directions, so the joint must balance in the others), loads
//! have a fixed position and carry external forces, free joints have variable positions.
//! Beams carry an axial force λ, positive in compression (seed convention).

use nalgebra::Vector3;

use super::mass::{Compression, MassModel};

/// 3-vector in metres or newtons.
pub type Vec3 = Vector3<f64>;

/// How an anchor is held.
#[derive(Debug, Clone, PartialEq)]
pub enum Support {
    /// Reactions in every direction: no force-balance rows.
    Pinned,
    /// Reactions only along these unit directions; the joint balances in the rest.
    Roller(Vec<Vec3>),
}

/// What a joint is.
#[derive(Debug, Clone, PartialEq)]
pub enum JointKind {
    /// Joined to the earth.
    Anchor(Support),
    /// Fixed position carrying external forces.
    Load,
    /// Position is a variable.
    Free,
}

/// A pin joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Position, m.
    pub position: Vec3,
    /// Kind.
    pub kind: JointKind,
    /// User name (for extra beams, forbidden pairs and load cases), if any.
    pub name: Option<String>,
    /// External force per load case, N (zero for joints without loads).
    pub loads: Vec<Vec3>,
}

impl Joint {
    /// Whether the position is a variable.
    pub fn is_free(&self) -> bool {
        matches!(self.kind, JointKind::Free)
    }

    /// Whether the joint is a pinned anchor (no balance rows at all).
    pub fn is_pinned(&self) -> bool {
        matches!(self.kind, JointKind::Anchor(Support::Pinned))
    }

    /// Whether the joint is an anchor of any support type.
    pub fn is_anchor(&self) -> bool {
        matches!(self.kind, JointKind::Anchor(_))
    }
}

/// A beam between two joints (indices into the joint list, `ends[0] != ends[1]`).
/// Its unit vector e points from `ends[0]` to `ends[1]`; in compression (λ > 0) it pushes
/// `ends[0]` along −e and `ends[1]` along +e.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Beam {
    /// Joint indices, smaller first.
    pub ends: [usize; 2],
}

impl Beam {
    /// A beam with its ends ordered (smaller index first).
    pub fn new(a: usize, b: usize) -> Self {
        Beam {
            ends: [a.min(b), a.max(b)],
        }
    }
}

/// Joints and beams.
#[derive(Debug, Clone, PartialEq)]
pub struct Structure {
    /// All joints.
    pub joints: Vec<Joint>,
    /// All beams.
    pub beams: Vec<Beam>,
}

impl Structure {
    /// Length of beam `j` at the stored positions, m.
    pub fn length(&self, j: usize) -> f64 {
        let [a, b] = self.beams[j].ends;
        (self.joints[b].position - self.joints[a].position).norm()
    }

    /// Number of free joints.
    pub fn free_count(&self) -> usize {
        self.joints.iter().filter(|j| j.is_free()).count()
    }
}

/// What the optimization minimizes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Objective {
    /// Total beam mass (kg).
    Mass,
    /// Total beam length (m).
    Length,
    /// Beam mass with compression members weighted by this factor (> 1 prefers cables).
    MassTensionPreference(f64),
}

/// A spherical or half-space region that joints and beams must stay out of (seed §4.3.3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Obstacle {
    /// Allowed: `(p − point)·normal ≥ 0` (seed eq. 4.9); `normal` is a unit vector.
    HalfSpace {
        /// A point on the plane, m.
        point: Vec3,
        /// Unit normal pointing into the allowed side.
        normal: Vec3,
    },
    /// Forbidden: the open ball `|p − center| < radius`, for joints and whole beam segments.
    Sphere {
        /// Centre, m.
        center: Vec3,
        /// Radius, m.
        radius: f64,
    },
}

impl Obstacle {
    /// Signed clearance of a point: ≥ 0 when allowed (m).
    pub fn clearance(&self, p: &Vec3) -> f64 {
        match self {
            Obstacle::HalfSpace { point, normal } => (p - point).dot(normal),
            Obstacle::Sphere { center, radius } => (p - center).norm() - radius,
        }
    }
}

/// A mirror plane: free joints are paired with their mirror images.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mirror {
    /// A point on the plane, m.
    pub point: Vec3,
    /// Unit normal.
    pub normal: Vec3,
}

impl Mirror {
    /// The mirror image of `p`.
    pub fn reflect(&self, p: &Vec3) -> Vec3 {
        p - 2.0 * (p - self.point).dot(&self.normal) * self.normal
    }
}

/// Everything besides the structure that defines the optimization problem.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// Physical beam mass (self-weight and the mass objective).
    pub mass: MassModel,
    /// Objective.
    pub objective: Objective,
    /// Whether beam self-weight is lumped into the joints (seed eq. 4.1).
    pub self_weight: bool,
    /// λ_max, N (bound on |λ|, seed eq. 4.3).
    pub max_force: f64,
    /// l_min, m (seed eq. 4.8).
    pub min_length: f64,
    /// Optional l_max, m.
    pub max_length: Option<f64>,
    /// Planar problem: everything in the plane z = const; z is neither a variable nor balanced.
    pub planar: bool,
    /// Free joints keep this coordinate (0 = x, 1 = y, 2 = z): they move in planes normal to it.
    pub held_axis: Option<usize>,
    /// Whether free joints move at all (false: sizing only, seed §4.3.2).
    pub move_joints: bool,
    /// Mirror planes.
    pub symmetry: Vec<Mirror>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Load-case names (the length of every joint's `loads`).
    pub load_cases: Vec<String>,
}

impl Settings {
    /// Which coordinates of a free joint are variables.
    pub fn variable_axes(&self) -> Vec<usize> {
        (0..3)
            .filter(|&k| self.move_joints && !(self.planar && k == 2) && self.held_axis != Some(k))
            .collect()
    }

    /// The coordinate directions in which joints must balance.
    pub fn balance_axes(&self) -> usize {
        if self.planar { 2 } else { 3 }
    }

    /// Whether the objective grows linearly with a compression member's length, as with a
    /// tension member's: `linear` compression mass, or the length objective. A free joint on
    /// a straight run of two members of one sign is then a flat direction whatever the sign
    /// (Euler struts are not: two halves weigh half the whole).
    pub fn compression_linear_in_length(&self) -> bool {
        self.objective == Objective::Length
            || matches!(self.mass.compression, Compression::Linear { .. })
    }

    /// Whether the objective is a mass linear in |λ| in both signs (`linear` mass, not the
    /// length objective): at fixed geometry the plastic layout LP, convex in each force.
    pub fn mass_linear_in_force(&self) -> bool {
        self.objective != Objective::Length
            && matches!(self.mass.compression, Compression::Linear { .. })
    }
}
