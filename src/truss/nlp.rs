//! The truss optimization problem (seed eq. 4.8) as an [`Nlp`], with exact sparse Jacobian and
//! exact Lagrangian Hessian.
//!
//! Variables (scaled so the solver sees O(1) numbers; F = largest external load in N, D = the
//! diagonal of the fixed joints' box in m (the span), M = k_T·F·D reference mass in kg):
//! - the force parts, first: per case and beam the tension part `t_jc/F` and the compression
//!   part `c_jc/F` (λ = F·(c − t), + compression), bounds `0 ≤ t, c ≤ λ_max/F` (eq. 4.3). With
//!   linear mass this makes the fixed-geometry problem exactly the plastic layout LP (see
//!   [`super::mass`]). A member whose sign is known may have only the part of that sign
//!   ([`ForceParts`]);
//! - positions of free joints divided by D, one variable per coordinate that may move (not the
//!   held axis, not z in planar problems);
//! - with several load cases only: `x_s[j] = s_j / M ≥ 0`, the mass of beam j sized for its worst
//!   case (below).
//!
//! Constraints, in row order:
//! 1. force balance (eq. 4.1) per case, per non-pinned joint, along an orthonormal basis of the
//!    directions the joint must balance in (all axes; for a roller the complement of its reaction
//!    directions; planar: x and y only), divided by F:
//!    `r·[Σ_j ±λ_jc e_j + ½ g Σ_j m_j + f_ic] / F = 0`, with −λe at the beam's first end and +λe at
//!    its second (compression pushes the ends apart). `m_j` is the beam's mass (self-weight,
//!    lumped half to each end), `m(λ_jc, L_j)` with one case and `s_j` with several;
//! 2. beam length `l_min/D ≤ L_j/D ≤ l_max/D` for beams with a free end (eq. 4.8);
//! 3. several cases only: `m(λ_jc, L_j)/M − s_j/M ≤ 0` for every case and beam. Minimizing Σ s_j
//!    makes s_j = max_c m(λ_jc, L_j) at the optimum: the worst case sizes the beam smoothly,
//!    without a max();
//! 4. symmetry: `(p_k − R(p_i))/D = 0` for mirror pairs, `n·(p − r)/D = 0` for joints on the
//!    plane;
//! 5. half-space obstacles (eq. 4.9): `n·(p_i − r)/D ≥ 0` for free joints (segments follow: the
//!    half-space is convex);
//! 6. sphere obstacles: `D(a_j, b_j)/R² ≥ 1` for beams with a free end, D the squared distance
//!    from the centre to the whole segment (see [`super::geometry`]).
//!
//! Objective: Σ m_j / M (mass), Σ m_w,j / M (mass with compression weighted, tension preference),
//! or Σ L_j / D (length of all beams). With several cases the mass objective is Σ s_j / M.
//!
//! Internally every derivative is first formed with respect to positions in metres and then
//! multiplied by D per position column (`TrussNlp::column_scale`).
//!
//! Patterns: entries are emitted by one walk over the model; duplicates are merged into a sorted
//! unique pattern once, so the Jacobian and Hessian patterns have no repeated pairs.

use std::collections::BTreeMap;

use crate::solver::log::ObjectiveUnit;

use nalgebra::{DMatrix, Matrix3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::geometry::{
    length_hessian, projection_gradient, projection_hessian, segment_distance_squared,
};
use super::mass::{MassDerivatives, MassModel, gravity};
use super::model::{JointKind, Objective, Obstacle, Settings, Structure, Support, Vec3};
use crate::solver::{Dims, EvalError, Nlp};

/// Why the problem could not be set up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SetupError {
    /// A free joint has no mirror image under a symmetry plane.
    #[error("symmetry plane {mirror}: the joint at {position:?} has no mirror image")]
    Asymmetric {
        /// Index of the mirror plane.
        mirror: usize,
        /// Position of the unpaired joint, m.
        position: [f64; 3],
    },
    /// The structure has no beams.
    #[error("the ground structure has no beams")]
    NoBeams,
}

/// Which parts of a beam's axial force (in one load case) are variables.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ForceParts {
    /// Tension t and compression c: the sign is free (ground structures).
    #[default]
    Both,
    /// Tension only (λ = −t ≤ 0).
    Tension,
    /// Compression only (λ = c ≥ 0).
    Compression,
}

impl ForceParts {
    /// The parts that carry a force of sign `lambda` (N, + compression): the sign of a nonzero
    /// force, both parts for zero.
    pub fn of(lambda: f64) -> Self {
        if lambda > 0.0 {
            ForceParts::Compression
        } else if lambda < 0.0 {
            ForceParts::Tension
        } else {
            ForceParts::Both
        }
    }
}

/// A linear constraint row `Σ coef·x + constant` (symmetry, half-space).
#[derive(Debug, Clone, PartialEq)]
struct LinearRow {
    terms: Vec<(usize, f64)>,
    constant: f64,
    lower: f64,
    upper: f64,
    what: String,
}

/// Rows of one joint's force balance (per case).
#[derive(Debug, Clone, PartialEq)]
struct BalanceJoint {
    joint: usize,
    /// Orthonormal directions the joint must balance in.
    basis: Vec<Vec3>,
    /// First row within a case block.
    offset: usize,
}

/// Which kind of row a constraint index is (for names).
#[derive(Debug, Clone, Copy)]
enum RowKind {
    Balance,
    Length,
    Size,
    Linear,
    Sphere,
}

/// Per-beam quantities at a point.
#[derive(Debug, Clone)]
struct BeamState {
    e: Vec3,
    length: f64,
    /// Physical mass derivatives per case.
    mass: Vec<MassDerivatives>,
}

/// Sorted unique (row, col) pattern with a slot for every emitted entry.
#[derive(Debug, Clone, Default)]
struct Pattern {
    rows: Vec<usize>,
    cols: Vec<usize>,
    slot: Vec<usize>,
}

impl Pattern {
    fn from_emissions(entries: &[(usize, usize)]) -> Self {
        let mut unique: BTreeMap<(usize, usize), usize> = BTreeMap::new();
        for &e in entries {
            unique.insert(e, 0);
        }
        for (k, v) in unique.values_mut().enumerate() {
            *v = k;
        }
        Pattern {
            rows: unique.keys().map(|k| k.0).collect(),
            cols: unique.keys().map(|k| k.1).collect(),
            slot: entries.iter().map(|e| unique[e]).collect(),
        }
    }
}

/// The truss NLP (module header). Built from a structure (start geometry) and settings.
#[derive(Debug, Clone)]
pub struct TrussNlp {
    structure: Structure,
    settings: Settings,
    /// Beams touching each joint: (beam, sign of λe at this end).
    adjacency: Vec<Vec<(usize, f64)>>,
    /// Variable index per joint per axis.
    position_vars: Vec<[Option<usize>; 3]>,
    /// [tension, compression] variable of beam j in case c at `c·beams + j`.
    force_vars: Vec<[Option<usize>; 2]>,
    /// Number of force variables (they come first).
    force_count: usize,
    cases: usize,
    beams: usize,
    n: usize,
    size_offset: Option<usize>,
    balance: Vec<BalanceJoint>,
    /// Balance rows per case.
    balance_rows: usize,
    /// Row of joint i's first balance row in case 0 (None if pinned).
    balance_of_joint: Vec<Option<usize>>,
    length_beams: Vec<usize>,
    length_offset: usize,
    size_row_offset: usize,
    linear: Vec<LinearRow>,
    linear_offset: usize,
    spheres: Vec<(usize, Vec3, f64)>,
    sphere_offset: usize,
    m: usize,
    start_forces: Vec<f64>,
    force_scale: f64,
    mass_scale: f64,
    length_scale: f64,
    objective_mass: MassModel,
    jacobian: Pattern,
    hessian: Pattern,
}

impl TrussNlp {
    /// Sets up the problem. `start_forces` (N, case-major, length cases·beams) is the start of λ.
    /// Every force has a tension and a compression part.
    pub fn new(
        structure: Structure,
        settings: Settings,
        start_forces: Vec<f64>,
    ) -> Result<Self, SetupError> {
        let parts = vec![ForceParts::Both; start_forces.len()];
        Self::with_parts(structure, settings, start_forces, parts)
    }

    /// As [`TrussNlp::new`], with the force parts that are variables given per case and beam
    /// (case-major): a member whose sign is known has only the part of that sign, which keeps the
    /// other part's coupling (the Euler mass's steep slope at zero force times the length) out of
    /// the Lagrangian Hessian.
    pub fn with_parts(
        structure: Structure,
        settings: Settings,
        start_forces: Vec<f64>,
        parts: Vec<ForceParts>,
    ) -> Result<Self, SetupError> {
        if structure.beams.is_empty() {
            return Err(SetupError::NoBeams);
        }
        let cases = settings.load_cases.len();
        let beams = structure.beams.len();
        assert_eq!(
            start_forces.len(),
            cases * beams,
            "start forces per case and beam"
        );
        let joints = &structure.joints;

        let mut adjacency = vec![Vec::new(); joints.len()];
        for (j, b) in structure.beams.iter().enumerate() {
            adjacency[b.ends[0]].push((j, -1.0));
            adjacency[b.ends[1]].push((j, 1.0));
        }

        assert_eq!(parts.len(), cases * beams, "force parts per case and beam");
        let mut n = 0;
        let mut next = || {
            n += 1;
            Some(n - 1)
        };
        let force_vars: Vec<[Option<usize>; 2]> = (parts.iter())
            .map(|p| match p {
                ForceParts::Both => [next(), next()],
                ForceParts::Tension => [next(), None],
                ForceParts::Compression => [None, next()],
            })
            .collect();
        let force_count = n;
        let axes = settings.variable_axes();
        let mut position_vars = vec![[None; 3]; joints.len()];
        for (i, joint) in joints.iter().enumerate() {
            if joint.is_free() {
                for &k in &axes {
                    position_vars[i][k] = Some(n);
                    n += 1;
                }
            }
        }
        let size_offset = (cases > 1).then(|| {
            let o = n;
            n += beams;
            o
        });

        let mut balance = Vec::new();
        let mut balance_rows = 0;
        let mut balance_of_joint = vec![None; joints.len()];
        for (i, joint) in joints.iter().enumerate() {
            let mut basis = balance_basis(&joint.kind, settings.balance_axes());
            if let Some(k) = idle_held_axis(&structure, &settings, &adjacency, i) {
                basis = without_axis(&basis, k);
            }
            if basis.is_empty() {
                continue;
            }
            balance_of_joint[i] = Some(balance_rows);
            let len = basis.len();
            balance.push(BalanceJoint {
                joint: i,
                basis,
                offset: balance_rows,
            });
            balance_rows += len;
        }
        let has_free_end = |j: usize| structure.beams[j].ends.iter().any(|&e| joints[e].is_free());
        let length_beams: Vec<usize> = (0..beams).filter(|&j| has_free_end(j)).collect();
        let length_offset = cases * balance_rows;
        let size_row_offset = length_offset + length_beams.len();
        let size_rows = if cases > 1 { cases * beams } else { 0 };
        let linear_offset = size_row_offset + size_rows;
        let mut linear = symmetry_rows(&structure, &settings, &position_vars)?;
        linear.extend(half_space_rows(&structure, &settings, &position_vars));
        let sphere_offset = linear_offset + linear.len();
        let spheres: Vec<(usize, Vec3, f64)> = (settings.obstacles.iter())
            .filter_map(|o| match o {
                Obstacle::Sphere { center, radius } => Some((*center, *radius)),
                Obstacle::HalfSpace { .. } => None,
            })
            .flat_map(|(c, r)| length_beams.iter().map(move |&j| (j, c, r)))
            .collect();
        let m = sphere_offset + spheres.len();

        let force_scale = joints
            .iter()
            .flat_map(|j| j.loads.iter())
            .map(|f| f.norm())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let length_scale = fixed_diagonal(&structure).max(settings.min_length);
        let mass_scale = settings.mass.k_t * force_scale * length_scale;
        let objective_mass = match settings.objective {
            Objective::MassTensionPreference(w) => settings.mass.with_compression_weight(w),
            _ => settings.mass,
        };
        let mut nlp = TrussNlp {
            structure,
            settings,
            adjacency,
            position_vars,
            force_vars,
            force_count,
            cases,
            beams,
            n,
            size_offset,
            balance,
            balance_rows,
            balance_of_joint,
            length_beams,
            length_offset,
            size_row_offset,
            linear,
            linear_offset,
            spheres,
            sphere_offset,
            m,
            start_forces,
            force_scale,
            mass_scale,
            length_scale,
            objective_mass,
            jacobian: Pattern::default(),
            hessian: Pattern::default(),
        };
        let mut x = vec![0.0; nlp.n];
        nlp.start(&mut x);
        let states = nlp.states_unchecked(&x);
        let mut jac = Vec::new();
        nlp.walk_jacobian(&x, &states, &mut |r, c, _| jac.push((r, c)));
        nlp.jacobian = Pattern::from_emissions(&jac);
        let mut hess = Vec::new();
        let zeros = vec![0.0; nlp.m];
        nlp.walk_hessian(&x, &states, 0.0, &zeros, &mut |r, c, _| {
            hess.push((r.max(c), r.min(c)))
        });
        nlp.hessian = Pattern::from_emissions(&hess);
        Ok(nlp)
    }

    /// Scale of variable `v`: D for positions, 1 for forces and sizes.
    fn column_scale(&self, v: usize) -> f64 {
        if self.position_variables().contains(&v) {
            self.length_scale
        } else {
            1.0
        }
    }

    /// The variable of each coordinate of joint `i` (None where it is fixed).
    pub fn joint_variables(&self, i: usize) -> [Option<usize>; 3] {
        self.position_vars[i]
    }

    /// Indices of the position variables (scaled by D).
    pub fn position_variables(&self) -> std::ops::Range<usize> {
        self.force_count..self.size_offset.unwrap_or(self.n)
    }

    /// Length scale D (the span), m.
    pub fn length_scale(&self) -> f64 {
        self.length_scale
    }

    /// Random starting forces: uniform in ±10% of the largest load, N (case-major).
    pub fn random_start_forces(structure: &Structure, cases: usize, seed: u64) -> Vec<f64> {
        let scale = structure
            .joints
            .iter()
            .flat_map(|j| j.loads.iter())
            .map(|f| f.norm())
            .fold(0.0, f64::max);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..cases * structure.beams.len())
            .map(|_| 0.1 * scale * (2.0 * rng.random::<f64>() - 1.0))
            .collect()
    }

    /// The force parts that are variables, per case and beam (case-major).
    pub fn parts(&self) -> Vec<ForceParts> {
        (self.force_vars.iter())
            .map(|v| match v {
                [Some(_), Some(_)] => ForceParts::Both,
                [Some(_), None] => ForceParts::Tension,
                _ => ForceParts::Compression,
            })
            .collect()
    }

    /// The structure the problem was built from (start geometry).
    pub fn structure(&self) -> &Structure {
        &self.structure
    }

    /// The settings.
    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Force scale F, N.
    pub fn force_scale(&self) -> f64 {
        self.force_scale
    }

    /// Mass scale M, kg.
    pub fn mass_scale(&self) -> f64 {
        self.mass_scale
    }

    /// How the objective is shown: mass in kg (Σ m / M times M), compression-weighted mass in
    /// kg, or length in m (Σ L / D times D).
    pub fn objective_unit(&self) -> ObjectiveUnit {
        match self.settings.objective {
            Objective::Mass => ObjectiveUnit::new("mass", "kg", self.mass_scale),
            Objective::MassTensionPreference(_) => {
                ObjectiveUnit::new("weighted mass", "kg", self.mass_scale)
            }
            Objective::Length => ObjectiveUnit::new("length", "m", self.length_scale),
        }
    }

    /// Beam forces λ in N, `[case][beam]`.
    pub fn forces(&self, x: &[f64]) -> Vec<Vec<f64>> {
        (0..self.cases)
            .map(|c| {
                (0..self.beams)
                    .map(|j| self.lambda(x, c, j) * self.force_scale)
                    .collect()
            })
            .collect()
    }

    /// Joint positions at `x`, m.
    pub fn positions(&self, x: &[f64]) -> Vec<Vec3> {
        (self.structure.joints.iter().zip(&self.position_vars))
            .map(|(j, vars)| {
                let mut p = j.position;
                for k in 0..3 {
                    if let Some(v) = vars[k] {
                        p[k] = x[v] * self.length_scale;
                    }
                }
                p
            })
            .collect()
    }

    /// Physical beam masses at `x`, kg: the worst case over load cases.
    pub fn beam_masses(&self, x: &[f64]) -> Vec<f64> {
        let p = self.positions(x);
        (self.structure.beams.iter().enumerate())
            .map(|(j, b)| {
                let len = (p[b.ends[1]] - p[b.ends[0]]).norm();
                (0..self.cases)
                    .map(|c| self.case_mass(&self.settings.mass, x, c, j, len).m)
                    .fold(0.0, f64::max)
            })
            .collect()
    }

    /// Scaled axial force λ/F of beam j in case c.
    fn lambda(&self, x: &[f64], c: usize, j: usize) -> f64 {
        let part = |v: Option<usize>| v.map_or(0.0, |v| x[v]);
        part(self.compression_var(c, j)) - part(self.tension_var(c, j))
    }

    /// Mass derivatives of beam j in case c under `model` at length `len` (m).
    fn case_mass(
        &self,
        model: &MassModel,
        x: &[f64],
        c: usize,
        j: usize,
        len: f64,
    ) -> MassDerivatives {
        let f = self.force_scale;
        model.derivatives(
            self.tension_var(c, j).map_or(0.0, |v| x[v]) * f,
            self.compression_var(c, j).map_or(0.0, |v| x[v]) * f,
            len,
        )
    }

    /// Largest force-balance residual over joints and cases at `x`, N (self-weight from
    /// [`TrussNlp::beam_masses`]-style lumping as in the constraints).
    pub fn max_balance_residual(&self, x: &[f64]) -> Result<f64, EvalError> {
        let mut f = 0.0;
        let mut c = vec![0.0; self.m];
        self.eval(x, &mut f, &mut c)?;
        Ok(c[..self.cases * self.balance_rows]
            .iter()
            .map(|v| v.abs() * self.force_scale)
            .fold(0.0, f64::max))
    }

    fn tension_var(&self, c: usize, j: usize) -> Option<usize> {
        self.force_vars[c * self.beams + j][0]
    }

    fn compression_var(&self, c: usize, j: usize) -> Option<usize> {
        self.force_vars[c * self.beams + j][1]
    }

    fn states_unchecked(&self, x: &[f64]) -> Vec<BeamState> {
        let p = self.positions(x);
        (self.structure.beams.iter().enumerate())
            .map(|(j, b)| {
                let d = p[b.ends[1]] - p[b.ends[0]];
                let length = d.norm();
                BeamState {
                    e: if length > 0.0 { d / length } else { Vec3::x() },
                    length: length.max(f64::MIN_POSITIVE),
                    mass: (0..self.cases)
                        .map(|c| self.case_mass(&self.settings.mass, x, c, j, length))
                        .collect(),
                }
            })
            .collect()
    }

    fn states(&self, x: &[f64]) -> Result<Vec<BeamState>, EvalError> {
        if let Some(i) = x.iter().position(|v| !v.is_finite()) {
            return Err(EvalError::Domain(format!("variable {i} is not finite")));
        }
        let p = self.positions(x);
        for (j, b) in self.structure.beams.iter().enumerate() {
            let len = (p[b.ends[1]] - p[b.ends[0]]).norm();
            if len.is_nan() || len <= 1e-12 * self.length_scale {
                return Err(EvalError::Domain(format!("beam {j} has zero length")));
            }
        }
        Ok(self.states_unchecked(x))
    }

    /// Self-weight per beam in case c (kg) and whether it comes from the size variable.
    fn beam_weight_mass(&self, x: &[f64], st: &BeamState, c: usize, j: usize) -> f64 {
        if !self.settings.self_weight {
            return 0.0;
        }
        match self.size_offset {
            Some(o) => x[o + j] * self.mass_scale,
            None => st.mass[c].m,
        }
    }

    /// Emits every Jacobian entry (row, col, value) in a fixed order.
    fn walk_jacobian(
        &self,
        x: &[f64],
        states: &[BeamState],
        emit: &mut dyn FnMut(usize, usize, f64),
    ) {
        let g = gravity();
        let f_scale = self.force_scale;
        let joints = &self.structure.joints;
        for c in 0..self.cases {
            for bj in &self.balance {
                for (k, r) in bj.basis.iter().enumerate() {
                    let row = c * self.balance_rows + bj.offset + k;
                    let rg = r.dot(&g);
                    for &(j, sign) in &self.adjacency[bj.joint] {
                        let st = &states[j];
                        let lambda = self.lambda(x, c, j) * f_scale;
                        let (m_t, m_c, m_len) =
                            if self.settings.self_weight && self.size_offset.is_none() {
                                (st.mass[c].m_t, st.mass[c].m_c, st.mass[c].m_len)
                            } else {
                                (0.0, 0.0, 0.0)
                            };
                        let re = sign * r.dot(&st.e);
                        if let Some(v) = self.tension_var(c, j) {
                            emit(row, v, -re + 0.5 * rg * m_t);
                        }
                        if let Some(v) = self.compression_var(c, j) {
                            emit(row, v, re + 0.5 * rg * m_c);
                        }
                        // ∂/∂d of r·(±λe) + ½ r·g m, divided by F.
                        let dd = (sign * lambda * projection_gradient(r, &st.e, st.length)
                            + 0.5 * rg * m_len * st.e)
                            / f_scale;
                        self.emit_ends(row, j, &dd, emit);
                        if let (Some(o), true) = (self.size_offset, self.settings.self_weight) {
                            emit(row, o + j, 0.5 * rg * self.mass_scale / f_scale);
                        }
                    }
                }
            }
        }
        for (k, &j) in self.length_beams.iter().enumerate() {
            let ds = states[j].e / self.length_scale;
            self.emit_ends(self.length_offset + k, j, &ds, emit);
        }
        if let Some(o) = self.size_offset {
            for c in 0..self.cases {
                for (j, st) in states.iter().enumerate() {
                    let row = self.size_row_offset + c * self.beams + j;
                    let md = &st.mass[c];
                    let k = f_scale / self.mass_scale;
                    if let Some(v) = self.tension_var(c, j) {
                        emit(row, v, md.m_t * k);
                    }
                    if let Some(v) = self.compression_var(c, j) {
                        emit(row, v, md.m_c * k);
                    }
                    self.emit_ends(row, j, &(md.m_len / self.mass_scale * st.e), emit);
                    emit(row, o + j, -1.0);
                }
            }
        }
        for (k, lr) in self.linear.iter().enumerate() {
            for &(col, coef) in &lr.terms {
                emit(self.linear_offset + k, col, coef / self.length_scale);
            }
        }
        let p = self.positions(x);
        for (k, &(j, center, radius)) in self.spheres.iter().enumerate() {
            let [a, b] = self.structure.beams[j].ends;
            let sd = segment_distance_squared(&p[a], &p[b], &center);
            let row = self.sphere_offset + k;
            let r2 = radius * radius;
            for (end, joint) in [a, b].into_iter().enumerate() {
                if !joints[joint].is_free() {
                    continue;
                }
                for axis in 0..3 {
                    if let Some(v) = self.position_vars[joint][axis] {
                        emit(row, v, sd.gradient[3 * end + axis] / r2);
                    }
                }
            }
        }
    }

    /// Emits ∂row/∂p_b = dd and ∂row/∂p_a = −dd for beam j (free coordinates only).
    fn emit_ends(&self, row: usize, j: usize, dd: &Vec3, emit: &mut dyn FnMut(usize, usize, f64)) {
        let [a, b] = self.structure.beams[j].ends;
        for (joint, sign) in [(a, -1.0), (b, 1.0)] {
            for axis in 0..3 {
                if let Some(v) = self.position_vars[joint][axis] {
                    emit(row, v, sign * dd[axis]);
                }
            }
        }
    }

    /// Emits the Lagrangian Hessian entries (any triangle; the caller folds to the lower one).
    fn walk_hessian(
        &self,
        x: &[f64],
        states: &[BeamState],
        sigma: f64,
        y: &[f64],
        emit: &mut dyn FnMut(usize, usize, f64),
    ) {
        let g = gravity();
        let (fs, ms) = (self.force_scale, self.mass_scale);
        let nc = self.cases;
        // Σ_r y_r·r per joint and case.
        let mut u = vec![Vec3::zeros(); self.structure.joints.len() * nc];
        for c in 0..nc {
            for bj in &self.balance {
                for (k, r) in bj.basis.iter().enumerate() {
                    u[bj.joint * nc + c] += y[c * self.balance_rows + bj.offset + k] * r;
                }
            }
        }
        let mut length_mult = vec![0.0; self.beams];
        for (k, &j) in self.length_beams.iter().enumerate() {
            length_mult[j] = y[self.length_offset + k] / self.length_scale;
        }
        let single_mass_objective = self.size_offset.is_none()
            && matches!(
                self.settings.objective,
                Objective::Mass | Objective::MassTensionPreference(_)
            );
        // Local variables: (t, c) per case, then the six end coordinates.
        let size = 2 * nc + 6;
        let (pa, pb) = (2 * nc, 2 * nc + 3);
        let mut h = DMatrix::<f64>::zeros(size, size);
        for (j, st) in states.iter().enumerate() {
            h.fill(0.0);
            let [a, b] = self.structure.beams[j].ends;
            let e = st.e;
            let hl = length_hessian(&e, st.length);
            let mut dd = Matrix3::<f64>::zeros();
            let mut length_coef = length_mult[j];
            if self.settings.objective == Objective::Length {
                length_coef += sigma / self.length_scale;
            }
            dd += length_coef * hl;
            for c in 0..nc {
                let lambda_hat = self.lambda(x, c, j);
                let yc = u[b * nc + c] - u[a * nc + c];
                let pg = projection_gradient(&yc, &e, st.length);
                let mut cross_t = -pg;
                let mut cross_c = pg;
                dd += lambda_hat * projection_hessian(&yc, &e, st.length);
                // Weighted physical-mass Hessian: self-weight (one case) and size rows.
                let mut w = 0.0;
                if self.settings.self_weight && self.size_offset.is_none() {
                    w += 0.5 * (u[a * nc + c] + u[b * nc + c]).dot(&g) / fs;
                }
                if self.size_offset.is_some() {
                    w += y[self.size_row_offset + c * self.beams + j] / ms;
                }
                let md = &st.mass[c];
                let mut cc = w * fs * fs * md.m_cc;
                cross_t += w * fs * md.m_t_len * e;
                cross_c += w * fs * md.m_c_len * e;
                dd += w * (md.m_len_len * e * e.transpose() + md.m_len * hl);
                if single_mass_objective {
                    let mo = self.case_mass(&self.objective_mass, x, c, j, st.length);
                    let s = sigma / ms;
                    cc += s * fs * fs * mo.m_cc;
                    cross_t += s * fs * mo.m_t_len * e;
                    cross_c += s * fs * mo.m_c_len * e;
                    dd += s * (mo.m_len_len * e * e.transpose() + mo.m_len * hl);
                }
                let (it, ic) = (2 * c, 2 * c + 1);
                h[(ic, ic)] += cc;
                for (i, cross) in [(it, cross_t), (ic, cross_c)] {
                    for k in 0..3 {
                        h[(i, pa + k)] -= cross[k];
                        h[(pa + k, i)] -= cross[k];
                        h[(i, pb + k)] += cross[k];
                        h[(pb + k, i)] += cross[k];
                    }
                }
            }
            for r in 0..3 {
                for s in 0..3 {
                    h[(pa + r, pa + s)] += dd[(r, s)];
                    h[(pb + r, pb + s)] += dd[(r, s)];
                    h[(pa + r, pb + s)] -= dd[(r, s)];
                    h[(pb + r, pa + s)] -= dd[(r, s)];
                }
            }
            let mut vars: Vec<Option<usize>> = (0..nc)
                .flat_map(|c| [self.tension_var(c, j), self.compression_var(c, j)])
                .collect();
            vars.extend(self.position_vars[a]);
            vars.extend(self.position_vars[b]);
            for r in 0..size {
                for s in 0..=r {
                    if let (Some(vr), Some(vs)) = (vars[r], vars[s]) {
                        emit(vr, vs, h[(r, s)]);
                    }
                }
            }
        }
        let p = self.positions(x);
        for (k, &(j, center, radius)) in self.spheres.iter().enumerate() {
            let [a, b] = self.structure.beams[j].ends;
            let sd = segment_distance_squared(&p[a], &p[b], &center);
            let mu = y[self.sphere_offset + k] / (radius * radius);
            let vars: Vec<Option<usize>> = self.position_vars[a]
                .into_iter()
                .chain(self.position_vars[b])
                .collect();
            for r in 0..6 {
                for s in 0..=r {
                    if let (Some(vr), Some(vs)) = (vars[r], vars[s]) {
                        emit(vr, vs, mu * sd.hessian[(r, s)]);
                    }
                }
            }
        }
    }

    fn row_kind(&self, row: usize) -> RowKind {
        if row < self.length_offset {
            RowKind::Balance
        } else if row < self.size_row_offset {
            RowKind::Length
        } else if row < self.linear_offset {
            RowKind::Size
        } else if row < self.sphere_offset {
            RowKind::Linear
        } else {
            RowKind::Sphere
        }
    }

    /// Constraint values at x, without checks (shared by `eval`).
    fn constraints(&self, x: &[f64], states: &[BeamState], c_out: &mut [f64]) {
        let g = gravity();
        for c in 0..self.cases {
            for bj in &self.balance {
                let joint = &self.structure.joints[bj.joint];
                let mut force = joint.loads[c];
                for &(j, sign) in &self.adjacency[bj.joint] {
                    let st = &states[j];
                    force += sign * self.lambda(x, c, j) * self.force_scale * st.e;
                    force += 0.5 * self.beam_weight_mass(x, st, c, j) * g;
                }
                for (k, r) in bj.basis.iter().enumerate() {
                    c_out[c * self.balance_rows + bj.offset + k] = r.dot(&force) / self.force_scale;
                }
            }
        }
        for (k, &j) in self.length_beams.iter().enumerate() {
            c_out[self.length_offset + k] = states[j].length / self.length_scale;
        }
        if let Some(o) = self.size_offset {
            for c in 0..self.cases {
                for (j, st) in states.iter().enumerate() {
                    c_out[self.size_row_offset + c * self.beams + j] =
                        st.mass[c].m / self.mass_scale - x[o + j];
                }
            }
        }
        for (k, lr) in self.linear.iter().enumerate() {
            c_out[self.linear_offset + k] = lr.constant / self.length_scale
                + lr.terms.iter().map(|&(v, a)| a * x[v]).sum::<f64>();
        }
        let p = self.positions(x);
        for (k, &(j, center, radius)) in self.spheres.iter().enumerate() {
            let [a, b] = self.structure.beams[j].ends;
            c_out[self.sphere_offset + k] =
                segment_distance_squared(&p[a], &p[b], &center).value / (radius * radius);
        }
    }

    fn objective(&self, x: &[f64], states: &[BeamState]) -> f64 {
        match (self.settings.objective, self.size_offset) {
            (Objective::Length, _) => {
                states.iter().map(|s| s.length).sum::<f64>() / self.length_scale
            }
            (_, Some(o)) => x[o..o + self.beams].iter().sum(),
            (_, None) => {
                (states.iter().enumerate())
                    .map(|(j, s)| self.case_mass(&self.objective_mass, x, 0, j, s.length).m)
                    .sum::<f64>()
                    / self.mass_scale
            }
        }
    }

    fn objective_gradient(&self, x: &[f64], states: &[BeamState], grad: &mut [f64]) {
        grad.fill(0.0);
        match (self.settings.objective, self.size_offset) {
            (Objective::Length, _) => {
                for (j, s) in states.iter().enumerate() {
                    self.add_end_gradient(j, &(s.e / self.length_scale), grad);
                }
            }
            (_, Some(o)) => grad[o..o + self.beams].fill(1.0),
            (_, None) => {
                for (j, s) in states.iter().enumerate() {
                    let md = self.case_mass(&self.objective_mass, x, 0, j, s.length);
                    let k = self.force_scale / self.mass_scale;
                    if let Some(v) = self.tension_var(0, j) {
                        grad[v] += md.m_t * k;
                    }
                    if let Some(v) = self.compression_var(0, j) {
                        grad[v] += md.m_c * k;
                    }
                    self.add_end_gradient(j, &(md.m_len / self.mass_scale * s.e), grad);
                }
            }
        }
        for (v, g) in grad.iter_mut().enumerate() {
            *g *= self.column_scale(v);
        }
    }

    fn add_end_gradient(&self, j: usize, dd: &Vec3, grad: &mut [f64]) {
        let [a, b] = self.structure.beams[j].ends;
        for (joint, sign) in [(a, -1.0), (b, 1.0)] {
            for axis in 0..3 {
                if let Some(v) = self.position_vars[joint][axis] {
                    grad[v] += sign * dd[axis];
                }
            }
        }
    }
}

impl Nlp for TrussNlp {
    fn dims(&self) -> Dims {
        Dims {
            n: self.n,
            m: self.m,
            jac_nnz: self.jacobian.rows.len(),
            hess_nnz: self.hessian.rows.len(),
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(f64::NEG_INFINITY);
        xu.fill(f64::INFINITY);
        let lmax = self.settings.max_force / self.force_scale;
        for v in 0..self.force_count {
            xl[v] = 0.0;
            xu[v] = lmax;
        }
        if let Some(o) = self.size_offset {
            xl[o..o + self.beams].fill(0.0);
        }
        cl.fill(0.0);
        cu.fill(0.0);
        for k in 0..self.length_beams.len() {
            cl[self.length_offset + k] = self.settings.min_length / self.length_scale;
            cu[self.length_offset + k] =
                self.settings.max_length.unwrap_or(f64::INFINITY) / self.length_scale;
        }
        if self.size_offset.is_some() {
            let rows = self.size_row_offset..self.linear_offset;
            cl[rows].fill(f64::NEG_INFINITY);
        }
        for (k, lr) in self.linear.iter().enumerate() {
            cl[self.linear_offset + k] = lr.lower / self.length_scale;
            cu[self.linear_offset + k] = lr.upper / self.length_scale;
        }
        for k in 0..self.spheres.len() {
            cl[self.sphere_offset + k] = 1.0;
            cu[self.sphere_offset + k] = f64::INFINITY;
        }
    }

    fn start(&self, x: &mut [f64]) {
        x.fill(0.0);
        let lmax = self.settings.max_force / self.force_scale;
        for (k, f) in self.start_forces.iter().enumerate() {
            let lambda = (f / self.force_scale).clamp(-lmax, lmax);
            let [t, c] = self.force_vars[k];
            match (t, c) {
                (Some(t), Some(c)) => {
                    x[t] = (-lambda).max(0.0);
                    x[c] = lambda.max(0.0);
                }
                (Some(t), None) => x[t] = (-lambda).max(0.0),
                (None, Some(c)) => x[c] = lambda.max(0.0),
                (None, None) => {}
            }
        }
        for (j, vars) in self.structure.joints.iter().zip(&self.position_vars) {
            for (k, var) in vars.iter().enumerate() {
                if let Some(v) = var {
                    x[*v] = j.position[k] / self.length_scale;
                }
            }
        }
        if let Some(o) = self.size_offset {
            for j in 0..self.beams {
                let len = self.structure.length(j);
                x[o + j] = (0..self.cases)
                    .map(|c| self.case_mass(&self.settings.mass, x, c, j, len).m)
                    .fold(0.0, f64::max)
                    / self.mass_scale;
            }
        }
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&self.jacobian.rows);
        cols.copy_from_slice(&self.jacobian.cols);
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        let states = self.states(x)?;
        *f = self.objective(x, &states);
        self.constraints(x, &states, c);
        if !f.is_finite() || c.iter().any(|v| !v.is_finite()) {
            return Err(EvalError::Domain(
                "non-finite objective or constraint".into(),
            ));
        }
        Ok(())
    }

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        let states = self.states(x)?;
        self.objective_gradient(x, &states, grad);
        jac.fill(0.0);
        let mut k = 0;
        let slot = &self.jacobian.slot;
        self.walk_jacobian(x, &states, &mut |_, col, v| {
            jac[slot[k]] += v * self.column_scale(col);
            k += 1;
        });
        if grad.iter().chain(jac.iter()).any(|v| !v.is_finite()) {
            return Err(EvalError::Domain("non-finite derivative".into()));
        }
        Ok(())
    }

    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        rows.copy_from_slice(&self.hessian.rows);
        cols.copy_from_slice(&self.hessian.cols);
    }

    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        let states = self.states(x)?;
        values.fill(0.0);
        let mut k = 0;
        let slot = &self.hessian.slot;
        self.walk_hessian(x, &states, sigma, lambda, &mut |r, col, v| {
            values[slot[k]] += v * self.column_scale(r) * self.column_scale(col);
            k += 1;
        });
        if values.iter().any(|v| !v.is_finite()) {
            return Err(EvalError::Domain("non-finite Hessian".into()));
        }
        Ok(())
    }

    fn constraint_name(&self, row: usize) -> String {
        match self.row_kind(row) {
            RowKind::Balance => {
                let c = row / self.balance_rows;
                let within = row % self.balance_rows;
                let bj = self
                    .balance
                    .iter()
                    .rfind(|b| b.offset <= within)
                    .expect("balance rows start at 0");
                format!(
                    "force balance {} of joint {} (case {})",
                    within - bj.offset,
                    bj.joint,
                    self.settings.load_cases[c]
                )
            }
            RowKind::Length => format!(
                "length of beam {}",
                self.length_beams[row - self.length_offset]
            ),
            RowKind::Size => {
                let k = row - self.size_row_offset;
                format!(
                    "size of beam {} for case {}",
                    k % self.beams,
                    self.settings.load_cases[k / self.beams]
                )
            }
            RowKind::Linear => self.linear[row - self.linear_offset].what.clone(),
            RowKind::Sphere => format!(
                "beam {} outside sphere obstacle",
                self.spheres[row - self.sphere_offset].0
            ),
        }
    }
}

impl TrussNlp {
    /// Sphere-obstacle rows: (row, beam, centre, radius).
    pub fn sphere_rows(&self) -> Vec<(usize, usize, Vec3, f64)> {
        (self.spheres.iter().enumerate())
            .map(|(k, &(j, c, r))| (self.sphere_offset + k, j, c, r))
            .collect()
    }

    /// Row of joint `i`'s first balance row in case `c`, if the joint balances at all.
    pub fn balance_row(&self, i: usize, c: usize) -> Option<usize> {
        self.balance_of_joint[i].map(|o| c * self.balance_rows + o)
    }
}

/// Orthonormal directions a joint must balance in: every axis of the problem's space, minus the
/// span of a roller's reactions; none for a pinned anchor.
pub(crate) fn balance_basis(kind: &JointKind, axes: usize) -> Vec<Vec3> {
    let space: Vec<Vec3> = (0..axes).map(|k| Vec3::ith(k, 1.0)).collect();
    let reactions: Vec<Vec3> = match kind {
        JointKind::Anchor(Support::Pinned) => return Vec::new(),
        JointKind::Anchor(Support::Roller(r)) => r.clone(),
        _ => Vec::new(),
    };
    // Orthonormalize the reactions projected into the space.
    let project = |v: &Vec3| -> Vec3 {
        let mut p = Vec3::zeros();
        for s in &space {
            p += s.dot(v) * s;
        }
        p
    };
    let mut spanned: Vec<Vec3> = Vec::new();
    for r in &reactions {
        let mut v = project(r);
        for s in &spanned {
            v -= v.dot(s) * s;
        }
        if v.norm() > 1e-9 {
            spanned.push(v.normalize());
        }
    }
    let mut basis: Vec<Vec3> = Vec::new();
    for s in &space {
        let mut v = *s;
        for q in spanned.iter().chain(basis.iter()) {
            v -= v.dot(q) * q;
        }
        if v.norm() > 1e-9 {
            basis.push(v.normalize());
        }
    }
    basis
}

/// The held axis k if joint i's balance along it vanishes identically: every beam at the joint
/// keeps both ends at the same coordinate k (free joints keep theirs, fixed joints do not move),
/// no load of any case and not gravity acts along k. The row `e_k·(Σ ±λe + ½gΣm + f) = 0` is
/// then `0 = 0` for every value of the variables, a dependent row that would leave its
/// multiplier undetermined (all-in-plane trusses of `hold_in_planes` problems).
fn idle_held_axis(
    structure: &Structure,
    settings: &Settings,
    adjacency: &[Vec<(usize, f64)>],
    i: usize,
) -> Option<usize> {
    let k = settings.held_axis?;
    let axis = Vec3::ith(k, 1.0);
    let joints = &structure.joints;
    let tol = 1e-12 * fixed_diagonal(structure).max(1.0);
    let in_plane = adjacency[i].iter().all(|&(j, _)| {
        let [a, b] = structure.beams[j].ends;
        (joints[a].position[k] - joints[b].position[k]).abs() <= tol
    });
    let unloaded = joints[i].loads.iter().all(|f| f[k] == 0.0);
    (in_plane && unloaded && gravity().dot(&axis) == 0.0).then_some(k)
}

/// An orthonormal basis of span(basis) projected on the complement of axis k.
fn without_axis(basis: &[Vec3], k: usize) -> Vec<Vec3> {
    let mut out: Vec<Vec3> = Vec::new();
    for b in basis {
        let mut v = *b;
        v[k] = 0.0;
        for q in &out {
            v -= v.dot(q) * q;
        }
        if v.norm() > 1e-9 {
            out.push(v.normalize());
        }
    }
    out
}

fn fixed_diagonal(s: &Structure) -> f64 {
    let mut lo = Vec3::repeat(f64::INFINITY);
    let mut hi = Vec3::repeat(f64::NEG_INFINITY);
    for j in s.joints.iter().filter(|j| !j.is_free()) {
        lo = lo.inf(&j.position);
        hi = hi.sup(&j.position);
    }
    (hi - lo).norm()
}

/// The setup checks of [`TrussNlp::new`] on `structure`, without building the NLP: beams exist,
/// and every free joint has a mirror image under each symmetry plane.
pub fn check_setup(structure: &Structure, settings: &Settings) -> Result<(), SetupError> {
    if structure.beams.is_empty() {
        return Err(SetupError::NoBeams);
    }
    // Without position variables the rows are all constant: only the images are checked.
    let vars = vec![[None; 3]; structure.joints.len()];
    symmetry_rows(structure, settings, &vars).map(|_| ())
}

/// Symmetry rows (module header, item 4).
fn symmetry_rows(
    s: &Structure,
    settings: &Settings,
    vars: &[[Option<usize>; 3]],
) -> Result<Vec<LinearRow>, SetupError> {
    let tol = 1e-6 * fixed_diagonal(s).max(settings.min_length);
    let mut rows = Vec::new();
    // A coordinate of joint i as (variable, constant).
    let coord = |i: usize, k: usize| -> (Option<usize>, f64) {
        match vars[i][k] {
            Some(v) => (Some(v), 0.0),
            None => (None, s.joints[i].position[k]),
        }
    };
    for (mi, mirror) in settings.symmetry.iter().enumerate() {
        let n = mirror.normal;
        for (i, joint) in s.joints.iter().enumerate() {
            if !joint.is_free() {
                continue;
            }
            let image = mirror.reflect(&joint.position);
            let Some(k) =
                (0..s.joints.len()).find(|&k| (s.joints[k].position - image).norm() <= tol)
            else {
                return Err(SetupError::Asymmetric {
                    mirror: mi,
                    position: [joint.position.x, joint.position.y, joint.position.z],
                });
            };
            // Keeps the row only if some variable appears in it (constant rows hold by pairing).
            let mut push = |terms: Vec<(Option<usize>, f64)>, constant: f64, what: String| {
                let terms: Vec<(usize, f64)> = (terms.into_iter())
                    .filter_map(|(v, a)| v.filter(|_| a != 0.0).map(|v| (v, a)))
                    .collect();
                if !terms.is_empty() {
                    rows.push(LinearRow {
                        terms,
                        constant,
                        lower: 0.0,
                        upper: 0.0,
                        what,
                    });
                }
            };
            if k == i {
                // On the plane: n·(p − r) = 0.
                let mut terms = Vec::new();
                let mut constant = -n.dot(&mirror.point);
                for ax in 0..3 {
                    let (v, c0) = coord(i, ax);
                    match v {
                        Some(_) => terms.push((v, n[ax])),
                        None => constant += n[ax] * c0,
                    }
                }
                push(terms, constant, format!("joint {i} on symmetry plane {mi}"));
            } else if s.joints[k].is_free() && k < i {
                // Pair rows were emitted from the smaller index.
            } else {
                // p_k − R(p_i) = 0 when k is free (k > i); p_i − R(p_k) = 0 when k is fixed.
                let (target, source) = if s.joints[k].is_free() {
                    (k, i)
                } else {
                    (i, k)
                };
                for ax in 0..3 {
                    // (R p)[ax] = p[ax] − 2 n_ax (n·p) + 2 n_ax (n·r)
                    let mut terms = Vec::new();
                    let mut constant = -2.0 * n[ax] * n.dot(&mirror.point);
                    let (vt, ct) = coord(target, ax);
                    match vt {
                        Some(_) => terms.push((vt, 1.0)),
                        None => constant += ct,
                    }
                    for bx in 0..3 {
                        let a = -(if ax == bx { 1.0 } else { 0.0 }) + 2.0 * n[ax] * n[bx];
                        let (vs, cs) = coord(source, bx);
                        match vs {
                            Some(_) => terms.push((vs, a)),
                            None => constant += a * cs,
                        }
                    }
                    push(
                        terms,
                        constant,
                        format!("joint {target} mirrors joint {source} (plane {mi}, axis {ax})"),
                    );
                }
            }
        }
    }
    Ok(rows)
}

/// Half-space rows for free joints (seed eq. 4.9).
fn half_space_rows(
    s: &Structure,
    settings: &Settings,
    vars: &[[Option<usize>; 3]],
) -> Vec<LinearRow> {
    let mut rows = Vec::new();
    for (oi, o) in settings.obstacles.iter().enumerate() {
        let Obstacle::HalfSpace { point, normal } = o else {
            continue;
        };
        for (i, joint) in s.joints.iter().enumerate() {
            if !joint.is_free() {
                continue;
            }
            let mut terms = Vec::new();
            let mut constant = -normal.dot(point);
            for ax in 0..3 {
                match vars[i][ax] {
                    Some(v) if normal[ax] != 0.0 => terms.push((v, normal[ax])),
                    Some(_) => {}
                    None => constant += normal[ax] * joint.position[ax],
                }
            }
            if !terms.is_empty() {
                rows.push(LinearRow {
                    terms,
                    constant,
                    lower: 0.0,
                    upper: f64::INFINITY,
                    what: format!("joint {i} on the allowed side of half-space {oi}"),
                });
            }
        }
    }
    rows
}
