//! The CMC optimization problem of seed eq. 5.4 as an [`Nlp`].
//!
//! Variables: the positions of the non-fixed vertices and one mean curvature `H_s` per surface
//! that has curvature vertices. Objective: the total area, plus the tangential regularization
//! below. Equality constraints, in row order:
//! 1. `H(x_j) − H_s = 0` at every curvature vertex j of surface s ([`Mesh::curvature_surface`]);
//! 2. `V(region) − V₀ = 0` for every volume constraint;
//! 3. `|x_a − x_b| − ℓ = 0` for every chord;
//! 4. the plane / line / circle equations of guided vertices ([`super::mesh::Guide`]).
//!
//! Scaling: internally lengths are divided by a characteristic length `L` (m), so variables are
//! `x/L` and `H·L`, the objective is `area/L²`, and the rows are `H·L`, `V/L³`, `ℓ/L` and guide
//! residuals `/L`. Millimetre bubbles and 50 m roofs then look alike to the solver.
//!
//! Triangle quality: the curvature rows fix each vertex's normal position only, leaving its
//! tangential position free, where the discrete area is nearly flat (a nearly singular Hessian)
//! and its minimization drifts towards slivers. We add the tangential regularization
//! ```text
//!   R(x) = (w/2) Σ_j |P_j (x_j − mean of x_j's neighbours)|²      (scaled units)
//! ```
//! over the curvature vertices j, with `P_j = I − n_j n_jᵀ` the tangent projector frozen at the
//! start of the solve (area-weighted normals). R pulls each vertex tangentially towards its ring
//! centroid (Laplacian smoothing within the surface) without resisting normal motion, so it
//! shapes the triangles and leaves the surface almost unchanged; its effect on the area is of
//! order `w` and is reported with the results (set `w = 0` to switch it off). It keeps one fixed
//! sparsity pattern per solve; connectivity is improved between solves by edge flips
//! ([`super::remesh`]), after which the problem is rebuilt ([`CmcNlp::remeshed`]).
//!
//! Exact Lagrangian Hessian `σ∇²f + Σ λ_r ∇²c_r` in scaled variables, lower triangle in 3×3
//! vertex blocks: area blocks of [`super::area::TriangleAreaForm`] (factor 1), the
//! regularization `w Σ c_a c_b PᵀP` (c = 1 at the vertex, −1/k on its k neighbours), curvature
//! rows `L³ ∇²H` ([`super::curvature_hessian`]), volume rows `∇²V / L`
//! ([`super::volume::cone_volume_hessian_row`]), chords `L (I − ûûᵀ)/|x_a − x_b|` and the circle
//! guide's second row `L/r · I`; plane and line guides and the `H_s` columns are linear.

use std::sync::{Arc, Mutex};

use nalgebra::Matrix3;
use rayon::prelude::*;

use super::area::{TriangleAreaForm, total_area, total_area_gradient};
use super::curvature::{mean_curvature, mean_curvature_gradient};
use super::curvature_hessian::mean_curvature_hessian;
use super::mesh::{Mesh, Point, orthonormal_pair};
use super::tangential::{Motion, Smoothing, over_relaxed, relax, vertex_normal};
use super::variables::{HessianPattern, Variables};
use super::volume::{Region, chord, cone_volume_hessian_row};
use crate::solver::global::WithStart;
use crate::solver::log::ObjectiveUnit;
use crate::solver::{Dims, EvalError, Nlp, Options, Solution};

/// A body: the region must enclose `target` m³, or, with a prescribed `pressure`, its volume
/// is free and the energy gets the term `−p·V` (Surface Evolver's `pressure`).
#[derive(Debug, Clone, PartialEq)]
pub struct VolumeConstraint {
    /// Name used in reports.
    pub name: String,
    /// The region.
    pub region: Region,
    /// Required volume, m³ (ignored when `pressure` is given).
    pub target: f64,
    /// Prescribed pressure p, 1/m (pressure over surface tension: J/m³ per N/m): no volume row,
    /// the objective is `A − p·V` and a surface bounding the region has `2H = p` at the
    /// solution (a spherical cap of radius 2/p).
    pub pressure: Option<f64>,
}

impl VolumeConstraint {
    /// A body that must enclose `target` m³ (no prescribed pressure).
    pub fn with_target(name: String, region: Region, target: f64) -> VolumeConstraint {
        VolumeConstraint {
            name,
            region,
            target,
            pressure: None,
        }
    }
}

/// A chord-length constraint: vertices `a` and `b` stay `length` m apart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chord {
    /// First vertex.
    pub a: usize,
    /// Second vertex.
    pub b: usize,
    /// Required distance, m.
    pub length: f64,
}

/// Which equations place the vertices in the normal direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Formulation {
    /// Seed eq. 5.4: a row `H(x_j) − H_s = 0` at every curvature vertex and one variable `H_s`
    /// per surface; the area is minimized under those rows.
    Curvature,
    /// Surface Evolver's: the area alone is minimized under the volume (chord, guide, gauge)
    /// rows; constant mean curvature is the optimality condition (`2H = p`, `p` the volume's
    /// multiplier), not a constraint, and the Meyer curvature spread of the solution is its
    /// check. No curvature rows, no `H_s` variables: a few rows instead of one per vertex and
    /// no curvature Hessians, 2–18× less CPU on problems/cmc than `Curvature`
    /// (docs/notes/cmc.md).
    Area,
    /// The area formulation in normal coordinates (Surface Evolver's `hessian_normal`; the
    /// default): a vertex inside one surface moves along its normal frozen at the start of a
    /// round (one variable instead of three, [`super::variables`]); a vertex inside a junction
    /// curve moves in the plane normal to the curve (two variables);
    /// other junction, guided and excluded vertices keep their three coordinates.
    /// [`CmcNlp::solve`] repeats rounds with a
    /// tangential relaxation between them ([`super::tangential`]), which reach the `Area`
    /// minimum; a first round that does not converge falls back to `Area`. On problems/cmc
    /// 2.5× less CPU than `Area` over the set, every file Optimal (docs/notes/cmc.md).
    #[default]
    Normal,
}

/// A normal-coordinate round that moves no vertex further than this (scaled units: lengths
/// over the characteristic length) ends the rounds ([`Formulation::Normal`]).
pub const ROUND_TOLERANCE: f64 = 1e-6;

/// At most this many normal-coordinate rounds per solve, by default.
pub const MAX_ROUNDS: usize = 8;

/// Tangential relaxation sweeps between two normal-coordinate rounds ([`relax`]).
pub const RELAXATION_SWEEPS: usize = 3;

/// The rounds end when the relaxation after a round lowers the energy by at most this
/// fraction of the area.
pub const RELAXATION_GAIN: f64 = 1e-5;

/// Largest per-round contraction `λ` of the rounds' energy error assumed when choosing the
/// over-relaxation `ω = 2 / (2 − λ)` between rounds (see [`CmcNlp::solve`]): caps ω at 1.82.
pub const MAX_CONTRACTION: f64 = 0.9;

/// Scaled optimality tolerance of a normal-coordinate round that another round may follow
/// (the solver's own tolerance when that is looser): the relaxation after it moves the film
/// tangentially and the next round starts at an optimality of ~1e-3 again, so digits beyond
/// this are undone; and a stationarity error ε leaves an energy error of order ε², far below
/// the [`RELAXATION_GAIN`] that decides whether another round follows. The round whose answer
/// is returned is then solved on to the solver's tolerance ([`CmcNlp::solve`]).
pub const ROUND_OPTIMALITY: f64 = 1e-4;

/// Largest turn of a junction curve at a vertex (degrees, between its two junction edges) for
/// which the vertex moves in the plane normal to the curve in normal coordinates
/// (`junction_planes`); where the curve turns more it is not resolved at the mesh's scale and
/// the vertex keeps its three coordinates. Without this limit the tetrahedral cluster's coarse
/// level (three edges per junction curve) stalled in its second round: 203 iterations instead of
/// 30 (docs/notes/cmc.md).
pub const JUNCTION_TURN: f64 = 30.0;

/// A first normal-coordinate round still unconverged after this many iterations is abandoned
/// for the area formulation ([`CmcNlp::solve`]).
pub const ROUND_ITERATIONS: usize = 100;

/// One constraint row's meaning.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Row {
    Curvature {
        vertex: usize,
        surface: usize,
    },
    Volume(usize),
    Chord(usize),
    Guide {
        vertex: usize,
        equation: usize,
    },
    /// Rigid-motion gauge of a free-floating mesh: k = 0..3 the mean position, k = 3..6 the
    /// mean of `(x⁰_v − c⁰) × x_v` (scaled), both held at their start values.
    Rigid(usize),
}

/// The CMC problem: see the module header.
#[derive(Debug)]
pub struct CmcNlp {
    start: Mesh,
    scratch: Mutex<Mesh>,
    scale: f64,
    vars: Variables,
    curvature_column: Vec<Option<usize>>,
    rows: Vec<Row>,
    volumes: Vec<VolumeConstraint>,
    chords: Vec<Chord>,
    smoothing: Vec<Smoothing>,
    weight: f64,
    /// The sparsity structure (Jacobian pattern, Hessian pattern and slots), shared with the
    /// problem it was rebuilt from when the connectivity and columns are the same
    /// ([`CmcNlp::remeshed`]).
    structure: Arc<Structure>,
    centre: Point,
    formulation: Formulation,
    /// The formulation [`CmcNlp::remeshed`] builds (`formulation` but after a fall-back).
    rebuilt_as: Formulation,
    max_rounds: usize,
    relaxation_gain: f64,
}

/// The Jacobian's and the Hessian's sparsity patterns of a problem, and the Hessian slots of
/// each triangle's corners and of each smoothing term's star ([`HessianPattern::star_slots`]):
/// functions of the connectivity, the rows and the variables' columns only.
#[derive(Debug, Default)]
struct Structure {
    pattern: Vec<(usize, usize)>,
    hessian: HessianPattern,
    triangle_slots: Vec<[usize; 9]>,
    smoothing_slots: Vec<Vec<usize>>,
}

/// Why a problem cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BuildError {
    /// A chord names a vertex that does not exist, or two equal vertices.
    #[error("chord {0} names a missing vertex or the same vertex twice")]
    BadChord(usize),
    /// Nothing can move.
    #[error("every vertex is fixed: there is nothing to optimize")]
    NothingFree,
    /// A quantity is non-finite or non-positive.
    #[error("{0}")]
    Invalid(String),
}

impl CmcNlp {
    /// Builds the curvature-row problem ([`Formulation::Curvature`]) from a start mesh;
    /// `tangential_weight` is `w` of the module header.
    pub fn new(
        mesh: Mesh,
        volumes: Vec<VolumeConstraint>,
        chords: Vec<Chord>,
        tangential_weight: f64,
    ) -> Result<CmcNlp, BuildError> {
        CmcNlp::with_formulation(
            mesh,
            volumes,
            chords,
            tangential_weight,
            Formulation::Curvature,
        )
    }

    /// Builds the problem in the given [`Formulation`] from a start mesh.
    pub fn with_formulation(
        mesh: Mesh,
        volumes: Vec<VolumeConstraint>,
        chords: Vec<Chord>,
        tangential_weight: f64,
        formulation: Formulation,
    ) -> Result<CmcNlp, BuildError> {
        CmcNlp::build(mesh, volumes, chords, tangential_weight, formulation, None)
    }

    /// [`CmcNlp::with_formulation`], taking the sparsity structure from `previous` when it is
    /// the same ([`CmcNlp::same_structure`]) instead of building it again.
    fn build(
        mesh: Mesh,
        volumes: Vec<VolumeConstraint>,
        chords: Vec<Chord>,
        tangential_weight: f64,
        formulation: Formulation,
        previous: Option<&CmcNlp>,
    ) -> Result<CmcNlp, BuildError> {
        if !(tangential_weight >= 0.0 && tangential_weight.is_finite()) {
            return Err(BuildError::Invalid(format!(
                "tangential weight must be ≥ 0, got {tangential_weight}"
            )));
        }
        for (i, c) in chords.iter().enumerate() {
            if c.a >= mesh.vertex_count() || c.b >= mesh.vertex_count() || c.a == c.b {
                return Err(BuildError::BadChord(i));
            }
        }
        let n = mesh.vertex_count();
        let junction_planes = match formulation {
            Formulation::Normal => junction_planes(&mesh, &chords),
            _ => vec![None; n],
        };
        let vars = Variables::new(
            |v| mesh.flags()[v].fixed,
            |v| {
                let normal = vertex_normal(&mesh, v);
                (formulation == Formulation::Normal
                    && mesh.curvature_surface(v).is_some()
                    && normal != Point::zeros())
                .then_some(normal)
            },
            |v| junction_planes[v],
            n,
        );
        if vars.count() == 0 {
            return Err(BuildError::NothingFree);
        }
        let mut next = vars.count();
        let curvature_vertices: Vec<(usize, usize)> = (0..n)
            .filter_map(|v| mesh.curvature_surface(v).map(|s| (v, s)))
            .collect();
        let mut curvature_column = vec![None; mesh.surfaces().len()];
        let curvature_rows: &[(usize, usize)] = match formulation {
            Formulation::Curvature => &curvature_vertices,
            Formulation::Area | Formulation::Normal => &[],
        };
        for &(_, s) in curvature_rows {
            if curvature_column[s].is_none() {
                curvature_column[s] = Some(usize::MAX);
            }
        }
        for slot in curvature_column.iter_mut().flatten() {
            *slot = next;
            next += 1;
        }
        let mut rows: Vec<Row> = curvature_rows
            .iter()
            .map(|&(vertex, surface)| Row::Curvature { vertex, surface })
            .collect();
        rows.extend(
            (0..volumes.len())
                .filter(|&k| volumes[k].pressure.is_none())
                .map(Row::Volume),
        );
        rows.extend((0..chords.len()).map(Row::Chord));
        for v in 0..n {
            if let (Some(g), Some(_)) = (mesh.flags()[v].guide, vars.column(v)) {
                for equation in 0..mesh.guides()[g].rows() {
                    rows.push(Row::Guide {
                        vertex: v,
                        equation,
                    });
                }
            }
        }
        let scale = characteristic_length(&mesh);
        let free_floating = mesh.flags().iter().all(|f| !f.fixed && f.guide.is_none());
        let centre = mesh.positions().iter().sum::<Point>() / n as f64 / scale;
        if free_floating {
            // A rotation moves a closed film tangentially, which normal coordinates cannot
            // express: only the translation gauge then.
            let gauges = if formulation == Formulation::Normal {
                3
            } else {
                6
            };
            rows.extend((0..gauges).map(Row::Rigid));
        }
        let smoothing = if tangential_weight > 0.0 {
            // A vertex moving along its normal has no tangential motion to regularize, unless
            // its ring holds a vertex with two or three coordinates (a junction's neighbour):
            // the term then keeps that vertex from sliding tangentially over the film. A
            // junction vertex moving in the plane normal to its curve cannot slide along it,
            // which its own term (along the curve) regularizes.
            smoothing_terms(&mesh, &vars)
                .into_iter()
                .filter(|term| {
                    !vars.is_normal(term.vertex) || term.ring.iter().any(|&w| vars.width(w) >= 2)
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut nlp = CmcNlp {
            scratch: Mutex::new(mesh.clone()),
            start: mesh,
            scale,
            vars,
            curvature_column,
            rows,
            volumes,
            chords,
            smoothing,
            weight: tangential_weight,
            structure: Arc::default(),
            centre,
            formulation,
            rebuilt_as: formulation,
            max_rounds: MAX_ROUNDS,
            relaxation_gain: RELAXATION_GAIN,
        };
        nlp.structure = match previous.filter(|p| nlp.same_structure(p)) {
            Some(previous) => Arc::clone(&previous.structure),
            None => Arc::new(nlp.build_structure()),
        };
        Ok(nlp)
    }

    /// The same problem (volumes, chords, weight) on another mesh with the same vertices and
    /// surfaces, e.g. after [`super::remesh::equiangulate`] or a normal-coordinate round (same
    /// connectivity: the sparsity structure is shared, not rebuilt).
    pub fn remeshed(&self, mesh: Mesh) -> Result<CmcNlp, BuildError> {
        self.reweighted(mesh, self.weight)
    }

    /// [`CmcNlp::remeshed`] with the tangential weight `weight` (`w` of the module header).
    pub fn reweighted(&self, mesh: Mesh, weight: f64) -> Result<CmcNlp, BuildError> {
        Ok(CmcNlp::build(
            mesh,
            self.volumes.clone(),
            self.chords.clone(),
            weight,
            self.rebuilt_as,
            Some(self),
        )?
        .with_rounds(self.max_rounds, self.relaxation_gain))
    }

    /// Whether `other` has this problem's sparsity structure: the same formulation,
    /// triangles, rows, curvature columns, columns of every vertex and smoothing terms'
    /// stars (the structure is a function of these alone).
    fn same_structure(&self, other: &CmcNlp) -> bool {
        let n = self.start.vertex_count();
        self.formulation == other.formulation
            && n == other.start.vertex_count()
            && self.start.triangles() == other.start.triangles()
            && self.rows == other.rows
            && self.curvature_column == other.curvature_column
            && self.vars.count() == other.vars.count()
            && (0..n).all(|v| {
                self.vars.column(v) == other.vars.column(v)
                    && self.vars.width(v) == other.vars.width(v)
            })
            && self.smoothing.len() == other.smoothing.len()
            && self
                .smoothing
                .iter()
                .zip(&other.smoothing)
                .all(|(a, b)| a.vertex == b.vertex && a.ring == b.ring)
    }

    /// The sparsity structure from scratch.
    fn build_structure(&self) -> Structure {
        let hessian = self.build_hessian_pattern();
        Structure {
            pattern: self.build_pattern(),
            triangle_slots: self
                .start
                .triangles()
                .iter()
                .map(|tri| hessian.triangle_slots(&self.vars, tri))
                .collect(),
            smoothing_slots: self
                .smoothing
                .iter()
                .map(|term| hessian.star_slots(&self.vars, &term.star()))
                .collect(),
            hessian,
        }
    }

    /// The formulation in use.
    pub fn formulation(&self) -> Formulation {
        self.formulation
    }

    /// The start mesh (connectivity, flags, fixed positions).
    pub fn mesh(&self) -> &Mesh {
        &self.start
    }

    /// The characteristic length `L` used for scaling, m.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Solves from the start mesh, the log showing the objective as area in m² (the NLP's
    /// area / L² times L²; the small regularization term is included) under `stage`.
    ///
    /// In normal coordinates ([`Formulation::Normal`]) the solve runs in rounds: after a
    /// converged round the mesh is relaxed tangentially ([`relax`], [`RELAXATION_SWEEPS`]
    /// sweeps at the round's pressures) and the problem rebuilt there (positions and normals
    /// frozen anew) and solved again, until the relaxation after a round lowers the energy by
    /// at most [`RELAXATION_GAIN`] of the area, or a round and the relaxation after it move no
    /// vertex by more than [`ROUND_TOLERANCE`], or after [`MAX_ROUNDS`] rounds (both settable,
    /// [`CmcNlp::with_rounds`]). From the second relaxation on, the mesh moves past the
    /// relaxed positions by the over-relaxation `ω = 2 / (2 − λ)`, λ the rounds' contraction
    /// estimated from the first two relaxations' gains ([`MAX_CONTRACTION`]), when that keeps
    /// every triangle and lowers the relaxation's energy. `self` becomes the last round's problem, the returned solution
    /// its solution, with the iterations, evaluations and logs of every round; a round that
    /// fails leaves the previous round's result. Every round but the last possible one stops
    /// at [`ROUND_OPTIMALITY`], and the returned round, when it stopped there, is solved on
    /// from its answer to the solver's tolerance. A first round that does not converge within
    /// [`ROUND_ITERATIONS`] is abandoned and the solve repeated in the area formulation
    /// (`CmcNlp::fall_back`).
    pub fn solve(&mut self, options: &Options, stage: &str) -> Solution {
        let mut options = options.clone();
        options.log.objective = ObjectiveUnit::new("area", "m²", self.scale * self.scale);
        options.log.stage = stage.to_string();
        if self.formulation != Formulation::Normal {
            return crate::solver::solve(&*self, &options);
        }
        let mut round_options = options.clone();
        round_options.max_iterations = options.max_iterations.min(ROUND_ITERATIONS);
        if self.max_rounds > 1 {
            round_options.tolerance = options.tolerance.max(ROUND_OPTIMALITY);
        }
        let mut solution = crate::solver::solve(&*self, &round_options);
        if !solution.status.is_success() {
            return self.fall_back(solution, &options, stage);
        }
        // Whether `solution` stopped at ROUND_OPTIMALITY rather than the solver's tolerance.
        let mut loose = round_options.tolerance > options.tolerance;
        let (mut first_gain, mut omega) = (None, None);
        for round in 2..=self.max_rounds {
            let moved = self.largest_displacement(&solution.x) > ROUND_TOLERANCE;
            let Ok(mut mesh) = self.mesh_at(&solution.x) else {
                break;
            };
            let terms = if self.weight > 0.0 {
                smoothing_terms(&mesh, &self.vars)
            } else {
                Vec::new()
            };
            let pressures = self.surface_pressures(&solution.lambda);
            let (relaxed, relaxation) = relax(
                &mesh,
                &pressures,
                |v| self.motion(v),
                &terms,
                self.weight,
                ROUND_TOLERANCE * self.scale,
                RELAXATION_SWEEPS,
            );
            let gain = relaxation.energy.0 - relaxation.energy.1;
            if gain <= self.relaxation_gain * total_area(&mesh)
                || (!moved && relaxation.last_move <= ROUND_TOLERANCE * self.scale)
            {
                break;
            }
            match first_gain {
                None => first_gain = Some(gain),
                Some(first) => {
                    omega.get_or_insert_with(|| over_relaxation(first, gain));
                }
            }
            let relaxed = omega
                .and_then(|omega| {
                    let start = relaxation.energy.0;
                    over_relaxed(
                        &mesh,
                        &relaxed,
                        omega,
                        start,
                        &pressures,
                        &terms,
                        self.weight,
                    )
                })
                .unwrap_or(relaxed);
            let Ok(next) = mesh
                .set_positions(relaxed)
                .map_err(|e| e.to_string())
                .and_then(|()| self.remeshed(mesh).map_err(|e| e.to_string()))
            else {
                break;
            };
            round_options.log.stage = match stage {
                "" => format!("round {round}"),
                _ => format!("{stage} round {round}"),
            };
            round_options.log.objective = ObjectiveUnit::new("area", "m²", next.scale * next.scale);
            if round == self.max_rounds {
                round_options.tolerance = options.tolerance;
            }
            let next_solution = crate::solver::solve(&next, &round_options);
            if !next_solution.status.is_success() {
                break;
            }
            *self = next;
            solution = merged(solution, next_solution);
            loose = round_options.tolerance > options.tolerance;
        }
        // A round that stopped at ROUND_OPTIMALITY may already meet the solver's tests
        // (optimality and violation, `Status::Optimal`); else it is solved on to them from its
        // answer (the status is then that solve's).
        loose &= solution.optimality > options.tolerance
            || solution.max_violation > options.constraint_tolerance;
        if loose {
            round_options.tolerance = options.tolerance;
            round_options.log.stage = match stage {
                "" => "final tolerance".to_string(),
                _ => format!("{stage} final tolerance"),
            };
            let finished =
                crate::solver::solve(&WithStart::new(&*self, solution.x.clone()), &round_options);
            solution = merged(solution, finished);
        }
        solution
    }

    /// After a first normal-coordinate round that ended `failed`: the same start solved in the
    /// area formulation (three coordinates per vertex), whose solution is returned with the
    /// failed round's iterations, evaluations and log; `self` becomes that problem, which
    /// rebuilds in normal coordinates again ([`CmcNlp::remeshed`], e.g. for the next level).
    fn fall_back(&mut self, failed: Solution, options: &Options, stage: &str) -> Solution {
        let Ok(area) = self.in_area_formulation(self.start.clone()) else {
            return failed;
        };
        let mut options = options.clone();
        options.log.stage = match stage {
            "" => "area formulation".to_string(),
            _ => format!("{stage} area formulation"),
        };
        let solution = crate::solver::solve(&area, &options);
        *self = area;
        merged(failed, solution)
    }

    /// The same problem (volumes, chords, weight, rounds) on `mesh` in the area formulation
    /// (three coordinates per vertex), which rebuilds in this problem's formulation
    /// ([`CmcNlp::remeshed`], e.g. for the next level).
    pub fn in_area_formulation(&self, mesh: Mesh) -> Result<CmcNlp, BuildError> {
        let mut area = CmcNlp::with_formulation(
            mesh,
            self.volumes.clone(),
            self.chords.clone(),
            self.weight,
            Formulation::Area,
        )?
        .with_rounds(self.max_rounds, self.relaxation_gain);
        area.rebuilt_as = self.rebuilt_as;
        Ok(area)
    }

    /// The same problem with at most `max_rounds` normal-coordinate rounds per solve (at
    /// least 1), ending earlier when a relaxation lowers the energy by at most `gain` of the
    /// area (see [`CmcNlp::solve`]; defaults [`MAX_ROUNDS`], [`RELAXATION_GAIN`]).
    pub fn with_rounds(mut self, max_rounds: usize, gain: f64) -> CmcNlp {
        self.max_rounds = max_rounds.max(1);
        self.relaxation_gain = gain;
        self
    }

    /// How [`relax`] may move vertex `v` between rounds: in its tangent plane when the rounds
    /// move it along its normal; in space when they move its three coordinates or a plane
    /// normal to its junction curve and no guide or chord holds it; else not at all.
    fn motion(&self, v: usize) -> Motion {
        let chord_end = self.chords.iter().any(|c| c.a == v || c.b == v);
        if self.vars.is_normal(v) {
            Motion::Tangential
        } else if self.vars.width(v) >= 2 && self.start.flags()[v].guide.is_none() && !chord_end {
            Motion::Free
        } else {
            Motion::Held
        }
    }

    /// The pressure jump across each surface (1/m) at a solution with multipliers `lambda`:
    /// `Σ_k σ_ks p_k` over the bodies k that surface s bounds (σ_ks = ±1), `p_k` the prescribed
    /// pressure or, for a held volume, `−λ/L` (the Lagrangian is `f + λᵀc` with `f = A/L²`
    /// and `c = (V − V₀)/L³` in variables `x/L`, so `∇A = −(λ/L) ∇V` at a solution).
    pub fn surface_pressures(&self, lambda: &[f64]) -> Vec<f64> {
        let mut body_pressure: Vec<f64> = self
            .volumes
            .iter()
            .map(|v| v.pressure.unwrap_or(0.0))
            .collect();
        for (row, &l) in self.rows.iter().zip(lambda) {
            if let Row::Volume(k) = *row {
                body_pressure[k] = -l / self.scale;
            }
        }
        let mut jump = vec![0.0; self.start.surfaces().len()];
        for (body, p) in self.volumes.iter().zip(&body_pressure) {
            for &(s, sign) in &body.region.boundary {
                jump[s] += sign * p;
            }
        }
        jump
    }

    /// The largest displacement of a vertex from its start position at `x`, in scaled units.
    pub fn largest_displacement(&self, x: &[f64]) -> f64 {
        self.start
            .positions()
            .iter()
            .enumerate()
            .map(|(v, p)| {
                let start = p / self.scale;
                (self.vars.position(v, start, x) - start).norm()
            })
            .fold(0.0, f64::max)
    }

    /// The volume constraints.
    pub fn volumes(&self) -> &[VolumeConstraint] {
        &self.volumes
    }

    /// Each body's region with its prescribed pressure (1/m), or `None` when its volume is
    /// held: the bodies as [`super::stability::analyse`] takes them.
    pub fn bodies(&self) -> Vec<(&Region, Option<f64>)> {
        self.volumes
            .iter()
            .map(|v| (&v.region, v.pressure))
            .collect()
    }

    /// The tangential regularization weight `w`.
    pub fn tangential_weight(&self) -> f64 {
        self.weight
    }

    /// Number of curvature rows.
    pub fn curvature_rows(&self) -> usize {
        self.rows
            .iter()
            .filter(|r| matches!(r, Row::Curvature { .. }))
            .count()
    }

    /// Vertex positions (m) at the variables `x`.
    pub fn positions(&self, x: &[f64]) -> Vec<Point> {
        self.start
            .positions()
            .iter()
            .enumerate()
            .map(|(v, p)| self.vars.position(v, p / self.scale, x) * self.scale)
            .collect()
    }

    /// Each surface's curvature variable `H_s` (1/m) at `x`; `None` for surfaces without
    /// curvature vertices.
    pub fn surface_curvatures(&self, x: &[f64]) -> Vec<Option<f64>> {
        self.curvature_column
            .iter()
            .map(|c| c.map(|c| x[c] / self.scale))
            .collect()
    }

    /// A copy of the mesh with the positions at `x`.
    pub fn mesh_at(&self, x: &[f64]) -> Result<Mesh, EvalError> {
        let mut mesh = self.start.clone();
        mesh.set_positions(self.positions(x))
            .map_err(|e| EvalError::Domain(e.to_string()))?;
        Ok(mesh)
    }

    /// The regularization term R(x) alone (scaled units, see the module header).
    pub fn regularization(&self, x: &[f64]) -> f64 {
        let pos = self.positions(x);
        self.smoothing
            .iter()
            .map(|term| {
                let r = term.projector * term.offset(&pos) / self.scale;
                0.5 * self.weight * r.norm_squared()
            })
            .sum()
    }

    /// Vertices each row depends on, in the order their gradients are produced.
    fn row_vertices(&self, row: Row) -> Vec<usize> {
        match row {
            Row::Curvature { vertex, .. } => {
                let mut v = vec![vertex];
                v.extend_from_slice(self.start.neighbours(vertex));
                v
            }
            Row::Volume(k) => self.volumes[k].region.vertices(&self.start),
            Row::Chord(k) => vec![self.chords[k].a, self.chords[k].b],
            Row::Guide { vertex, .. } => vec![vertex],
            Row::Rigid(_) => (0..self.start.vertex_count()).collect(),
        }
    }

    /// Value and per-vertex gradients (scaled variables) of rigid-motion row `k`.
    fn rigid_row(&self, k: usize, pos: &[Point]) -> (f64, Vec<(usize, Point)>) {
        let n = pos.len() as f64;
        let l = self.scale;
        let mut value = 0.0;
        let mut grad = Vec::with_capacity(pos.len());
        for (v, p) in pos.iter().enumerate() {
            let x = p / l;
            if k < 3 {
                value += (x[k] - self.centre[k]) / n;
                grad.push((v, Point::ith(k, 1.0 / n)));
            } else {
                let a = self.start.positions()[v] / l - self.centre;
                value += a.cross(&x)[k - 3] / n;
                // ∂(a × x)_k/∂x_j = (a × e_j)_k.
                let g = Point::from_fn(|j, _| a.cross(&Point::ith(j, 1.0))[k - 3] / n);
                grad.push((v, g));
            }
        }
        (value, grad)
    }

    /// The bodies with a prescribed pressure, with that pressure (1/m).
    fn pressure_bodies(&self) -> impl Iterator<Item = (&VolumeConstraint, f64)> {
        self.volumes
            .iter()
            .filter_map(|v| v.pressure.map(|p| (v, p)))
    }

    /// `Σ p·V` over the bodies with a prescribed pressure (m², the energy's pressure term).
    fn pressure_work(&self, mesh: &Mesh) -> f64 {
        self.pressure_bodies()
            .map(|(body, p)| p * body.region.volume(mesh))
            .sum()
    }

    /// Adds `factor ·` triangle t's corner blocks `M_km` (corners `tri`) to the Hessian
    /// values, each given by `rows(k, m, x) = M_kmᵀ x` (see [`HessianPattern::add_rows_at`]).
    fn add_triangle(
        &self,
        values: &mut [f64],
        t: usize,
        tri: &[usize; 3],
        rows: impl Fn(usize, usize, &Point) -> Point,
        factor: f64,
    ) {
        let slots = &self.structure.triangle_slots[t];
        for k in 0..3 {
            for m in 0..3 {
                HessianPattern::add_rows_at(
                    values,
                    &self.vars,
                    slots[3 * k + m],
                    tri[k],
                    tri[m],
                    |x| rows(k, m, x),
                    factor,
                );
            }
        }
    }

    fn build_pattern(&self) -> Vec<(usize, usize)> {
        let mut pattern = Vec::new();
        for (r, &row) in self.rows.iter().enumerate() {
            for v in self.row_vertices(row) {
                if let Some(c) = self.vars.column(v) {
                    pattern.extend((0..self.vars.width(v)).map(|k| (r, c + k)));
                }
            }
            if let Row::Curvature { surface, .. } = row
                && let Some(c) = self.curvature_column[surface]
            {
                pattern.push((r, c));
            }
        }
        pattern
    }

    /// Vertex pairs coupled in the Lagrangian Hessian: triangle corners (area, volume), closed
    /// stars of curvature and smoothed vertices, chord ends.
    fn build_hessian_pattern(&self) -> HessianPattern {
        let mut h = HessianPattern::default();
        let mesh = &self.start;
        for tri in mesh.triangles() {
            h.insert_star(&self.vars, tri);
        }
        for row in &self.rows {
            if let Row::Curvature { vertex, .. } = *row {
                let mut star = vec![vertex];
                star.extend_from_slice(mesh.neighbours(vertex));
                h.insert_star(&self.vars, &star);
            }
        }
        for term in &self.smoothing {
            h.insert_star(&self.vars, &term.star());
        }
        for ch in &self.chords {
            for (u, w) in [(ch.a, ch.a), (ch.a, ch.b), (ch.b, ch.b)] {
                h.insert(&self.vars, u, w);
            }
        }
        for v in 0..mesh.vertex_count() {
            h.insert(&self.vars, v, v);
        }
        h
    }

    /// Runs `f` on the scratch mesh moved to `x`.
    fn with_mesh<T>(
        &self,
        x: &[f64],
        f: impl FnOnce(&Mesh) -> Result<T, EvalError>,
    ) -> Result<T, EvalError> {
        if x.iter().any(|v| !v.is_finite()) {
            return Err(EvalError::Domain("non-finite variable".into()));
        }
        let mut mesh = self
            .scratch
            .lock()
            .map_err(|_| EvalError::Fatal("mesh scratch poisoned".into()))?;
        mesh.set_positions(self.positions(x))
            .map_err(|e| EvalError::Domain(e.to_string()))?;
        f(&mesh)
    }
}

/// `later` with the iterations, evaluations, seconds and log of `earlier` before its own.
pub(super) fn merged(mut earlier: Solution, mut later: Solution) -> Solution {
    later.iterations += earlier.iterations;
    later.evaluations.functions += earlier.evaluations.functions;
    later.evaluations.derivatives += earlier.evaluations.derivatives;
    later.evaluations.hessians += earlier.evaluations.hessians;
    later.seconds += earlier.seconds;
    earlier.log.append(&mut later.log);
    later.log = earlier.log;
    later
}

/// The over-relaxation ω of the relaxation's displacement between rounds, from the energy
/// gains `first` and `second` of the first two relaxations. The rounds alternate a normal
/// solve with a tangential relaxation (block coordinate descent); near the solution the error
/// contracts per round by an iteration matrix M with eigenvalues in [0, λ], the energy error
/// by about λ², so `λ ≈ √(second/first)`. The relaxed iteration `(1 − ω) I + ω M` contracts
/// fastest at `ω = 2 / (2 − λ)` (to `λ / (2 − λ)`), λ capped at [`MAX_CONTRACTION`].
fn over_relaxation(first: f64, second: f64) -> f64 {
    let contraction = (second / first).clamp(0.0, 1.0).sqrt().min(MAX_CONTRACTION);
    2.0 / (2.0 - contraction)
}

/// The bounding-box diagonal over √3 (the edge of a cube with that diagonal), m; 1 for a
/// single point.
fn characteristic_length(mesh: &Mesh) -> f64 {
    let mut lo = Point::repeat(f64::INFINITY);
    let mut hi = Point::repeat(f64::NEG_INFINITY);
    for p in mesh.positions() {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    let d = (hi - lo).norm() / 3f64.sqrt();
    if d > 0.0 { d } else { 1.0 }
}

/// The area formulation's regularization terms: one per curvature vertex (`P = I − n nᵀ`, the
/// ring its neighbours), then those of [`junction_smoothing`].
fn smoothing_terms(mesh: &Mesh, vars: &Variables) -> Vec<Smoothing> {
    let mut terms: Vec<Smoothing> = (0..mesh.vertex_count())
        .filter(|&v| mesh.curvature_surface(v).is_some())
        .map(|v| {
            let normal = vertex_normal(mesh, v);
            Smoothing {
                vertex: v,
                projector: Matrix3::identity() - normal * normal.transpose(),
                ring: mesh.neighbours(v).to_vec(),
            }
        })
        .collect();
    terms.extend(junction_smoothing(mesh, vars));
    terms
}

/// Each vertex's neighbours across junction edges (edges of three or more triangles).
fn junction_neighbours(mesh: &Mesh) -> Vec<Vec<usize>> {
    let mut along: Vec<Vec<usize>> = vec![Vec::new(); mesh.vertex_count()];
    for e in mesh.edges().iter().filter(|e| e.triangles.len() >= 3) {
        let [a, b] = e.vertices;
        along[a].push(b);
        along[b].push(a);
    }
    along
}

/// The plane each free vertex inside a junction curve moves in, in normal coordinates (two
/// orthonormal vectors normal to the curve's direction between its two junction neighbours at
/// the start; Surface Evolver's `hessian_normal` on a triple line): sliding along the curve
/// only reparametrizes it (zero curvature but for the regularization, a nearly singular reduced
/// Hessian whose long steps cost the SQP iterations), and the tangential relaxation between
/// rounds moves such a vertex in space. `None` for other vertices: those with another number of
/// junction edges (where curves meet or end), guided, excluded or fixed ones, chord ends, and
/// vertices where the curve turns by more than [`JUNCTION_TURN`].
fn junction_planes(mesh: &Mesh, chords: &[Chord]) -> Vec<Option<(Point, Point)>> {
    junction_neighbours(mesh)
        .iter()
        .enumerate()
        .map(|(v, ring)| {
            let f = mesh.flags()[v];
            let chord_end = chords.iter().any(|c| c.a == v || c.b == v);
            if ring.len() != 2 || f.fixed || f.excluded || f.guide.is_some() || chord_end {
                return None;
            }
            let p = mesh.positions();
            let t = (p[ring[1]] - p[ring[0]]).try_normalize(0.0)?;
            let before = (p[v] - p[ring[0]]).try_normalize(0.0)?;
            let after = (p[ring[1]] - p[v]).try_normalize(0.0)?;
            (before.dot(&after) >= JUNCTION_TURN.to_radians().cos()).then(|| orthonormal_pair(&t))
        })
        .collect()
}

/// Regularization terms for free vertices inside a junction curve (exactly two junction
/// edges): `P = t tᵀ` with `t` the curve's direction between the two junction neighbours at the
/// start, ring = those neighbours. Without it a vertex slides along a straight junction at no
/// cost (an exactly singular reduced Hessian); films' normal balance is untouched.
fn junction_smoothing(mesh: &Mesh, vars: &Variables) -> Vec<Smoothing> {
    junction_neighbours(mesh)
        .into_iter()
        .enumerate()
        .filter(|(v, ring)| {
            ring.len() == 2 && vars.column(*v).is_some() && mesh.curvature_surface(*v).is_none()
        })
        .filter_map(|(v, ring)| {
            let t = (mesh.positions()[ring[1]] - mesh.positions()[ring[0]]).try_normalize(0.0)?;
            Some(Smoothing {
                vertex: v,
                projector: t * t.transpose(),
                ring,
            })
        })
        .collect()
}

fn domain(e: impl std::fmt::Display) -> EvalError {
    EvalError::Domain(e.to_string())
}

impl Nlp for CmcNlp {
    fn dims(&self) -> Dims {
        Dims {
            n: self.vars.count() + self.curvature_column.iter().flatten().count(),
            m: self.rows.len(),
            jac_nnz: self.structure.pattern.len(),
            hess_nnz: self.structure.hessian.entries().len(),
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(f64::NEG_INFINITY);
        xu.fill(f64::INFINITY);
        cl.fill(0.0);
        cu.fill(0.0);
    }

    fn start(&self, x: &mut [f64]) {
        for (v, p) in self.start.positions().iter().enumerate() {
            self.vars.set_start(v, p / self.scale, x);
        }
        let mut sums = vec![(0.0, 0usize); self.curvature_column.len()];
        for row in &self.rows {
            if let Row::Curvature { vertex, surface } = *row
                && let Ok(h) = mean_curvature(&self.start, vertex)
            {
                sums[surface].0 += h;
                sums[surface].1 += 1;
            }
        }
        for (s, col) in self.curvature_column.iter().enumerate() {
            if let Some(c) = col {
                let (sum, count) = sums[s];
                x[*c] = if count > 0 {
                    sum / count as f64 * self.scale
                } else {
                    0.0
                };
            }
        }
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for (k, &(r, c)) in self.structure.pattern.iter().enumerate() {
            rows[k] = r;
            cols[k] = c;
        }
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        let l = self.scale;
        let reg = self.regularization(x);
        self.with_mesh(x, |mesh| {
            *f = (total_area(mesh) - self.pressure_work(mesh)) / (l * l) + reg;
            for (r, row) in self.rows.iter().enumerate() {
                c[r] = match *row {
                    Row::Curvature { vertex, surface } => {
                        let h = mean_curvature(mesh, vertex).map_err(domain)?;
                        let col = self.curvature_column[surface].unwrap_or(0);
                        h * l - x[col]
                    }
                    Row::Volume(k) => {
                        let v = &self.volumes[k];
                        (v.region.volume(mesh) - v.target) / (l * l * l)
                    }
                    Row::Chord(k) => {
                        let ch = self.chords[k];
                        (chord(mesh, ch.a, ch.b).0 - ch.length) / l
                    }
                    Row::Guide { vertex, equation } => {
                        let g = &mesh.guides()[mesh.flags()[vertex].guide.unwrap_or(0)];
                        g.residuals(&mesh.positions()[vertex])[equation].0 / l
                    }
                    Row::Rigid(k) => self.rigid_row(k, mesh.positions()).0,
                };
            }
            if f.is_finite() && c.iter().all(|v| v.is_finite()) {
                Ok(())
            } else {
                Err(EvalError::Domain("non-finite area or constraint".into()))
            }
        })
    }

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        let l = self.scale;
        grad.fill(0.0);
        let pos = self.positions(x);
        for term in &self.smoothing {
            let p = term.projector;
            let r = p * term.offset(&pos) / l;
            let g = self.weight * p.transpose() * r;
            self.vars.add_gradient(grad, term.vertex, g);
            for &w in &term.ring {
                self.vars.add_gradient(grad, w, -g / term.ring.len() as f64);
            }
        }
        self.with_mesh(x, |mesh| {
            for (v, g) in total_area_gradient(mesh).into_iter().enumerate() {
                self.vars.add_gradient(grad, v, g / l);
            }
            for (body, p) in self.pressure_bodies() {
                for (v, g) in body.region.volume_gradient(mesh) {
                    self.vars.add_gradient(grad, v, -p * g / l);
                }
            }
            let mut k = 0;
            let vars = &self.vars;
            let put = |jac: &mut [f64], k: &mut usize, list: Vec<(usize, Point)>, factor: f64| {
                for (v, g) in list {
                    vars.put_jacobian(jac, k, v, g * factor);
                }
            };
            for row in &self.rows {
                match *row {
                    Row::Curvature { vertex, surface } => {
                        let (_, g) = mean_curvature_gradient(mesh, vertex).map_err(domain)?;
                        put(jac, &mut k, g, l * l);
                        if self.curvature_column[surface].is_some() {
                            jac[k] = -1.0;
                            k += 1;
                        }
                    }
                    Row::Volume(i) => {
                        put(
                            jac,
                            &mut k,
                            self.volumes[i].region.volume_gradient(mesh),
                            1.0 / (l * l),
                        );
                    }
                    Row::Chord(i) => {
                        let ch = self.chords[i];
                        let (_, g) = chord(mesh, ch.a, ch.b);
                        put(jac, &mut k, vec![(ch.a, g), (ch.b, -g)], 1.0);
                    }
                    Row::Guide { vertex, equation } => {
                        let g = &mesh.guides()[mesh.flags()[vertex].guide.unwrap_or(0)];
                        let (_, d) = g.residuals(&mesh.positions()[vertex])[equation];
                        put(jac, &mut k, vec![(vertex, d)], 1.0);
                    }
                    Row::Rigid(r) => {
                        put(jac, &mut k, self.rigid_row(r, mesh.positions()).1, 1.0);
                    }
                }
            }
            debug_assert_eq!(k, self.structure.pattern.len());
            if grad.iter().chain(jac.iter()).all(|v| v.is_finite()) {
                Ok(())
            } else {
                Err(EvalError::Domain("non-finite derivative".into()))
            }
        })
    }

    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for (k, &(r, c)) in self.structure.hessian.entries().iter().enumerate() {
            rows[k] = r;
            cols[k] = c;
        }
    }

    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        let l = self.scale;
        let vars = &self.vars;
        let h = &self.structure.hessian;
        values.fill(0.0);
        // Regularization (quadratic in the scaled variables): w Σ c_a c_b PᵀP.
        for (term, slots) in self.smoothing.iter().zip(&self.structure.smoothing_slots) {
            let p = term.projector;
            let ptp = p.transpose() * p * (sigma * self.weight);
            let c_ring = -1.0 / term.ring.len() as f64;
            let star =
                std::iter::once((term.vertex, 1.0)).chain(term.ring.iter().map(|&w| (w, c_ring)));
            let mut slot = slots.iter();
            for (a, ca) in star.clone() {
                for ((b, cb), &s) in star.clone().zip(&mut slot) {
                    HessianPattern::add_at(values, vars, s, a, b, &ptp, ca * cb);
                }
            }
        }
        self.with_mesh(x, |mesh| {
            for (t, tri) in mesh.triangles().iter().enumerate() {
                let form = TriangleAreaForm::new(&mesh.corners(t));
                self.add_triangle(values, t, tri, |k, m, x| form.row(k, m, x), sigma);
            }
            let curvature: Vec<(usize, f64)> = self
                .rows
                .iter()
                .zip(lambda)
                .filter_map(|(row, &lam)| match *row {
                    Row::Curvature { vertex, .. } if lam != 0.0 => Some((vertex, lam)),
                    _ => None,
                })
                .collect();
            let stars = curvature
                .par_iter()
                .map(|&(v, _)| mean_curvature_hessian(mesh, v).map_err(domain))
                .collect::<Result<Vec<_>, _>>()?;
            for ((_, lam), (vertices, hess)) in curvature.iter().zip(&stars) {
                for (a, &u) in vertices.iter().enumerate() {
                    for (b, &w) in vertices.iter().enumerate() {
                        let block: Matrix3<f64> =
                            hess.fixed_view::<3, 3>(3 * a, 3 * b).into_owned();
                        h.add(values, vars, u, w, &block, lam * l * l * l);
                    }
                }
            }
            // ∇²V / L in scaled variables, times `factor`.
            let add_volume = |values: &mut [f64], region: &Region, factor: f64| {
                for &(s, sign) in &region.boundary {
                    for t in mesh.surface_triangles(s) {
                        let tri = mesh.triangles()[t];
                        let q = mesh.corners(t).map(|p| p - region.reference);
                        let rows = |k, m, x: &Point| cone_volume_hessian_row(&q, k, m, x);
                        self.add_triangle(values, t, &tri, rows, factor * sign);
                    }
                }
            };
            for (body, p) in self.pressure_bodies() {
                add_volume(values, &body.region, -sigma * p);
            }
            for (row, &lam) in self.rows.iter().zip(lambda) {
                if lam == 0.0 {
                    continue;
                }
                match *row {
                    Row::Curvature { .. } | Row::Rigid(_) => {}
                    Row::Volume(i) => add_volume(values, &self.volumes[i].region, lam / l),
                    Row::Chord(i) => {
                        let ch = self.chords[i];
                        let (len, u) = chord(mesh, ch.a, ch.b);
                        let m = (Matrix3::identity() - u * u.transpose()) / len;
                        let f = lam * l;
                        h.add(values, vars, ch.a, ch.a, &m, f);
                        h.add(values, vars, ch.b, ch.b, &m, f);
                        h.add(values, vars, ch.a, ch.b, &m, -f);
                        h.add(values, vars, ch.b, ch.a, &m, -f);
                    }
                    Row::Guide { vertex, equation } => {
                        let g = &mesh.guides()[mesh.flags()[vertex].guide.unwrap_or(0)];
                        if let (super::mesh::Guide::Circle { radius, .. }, 1) = (g, equation) {
                            let m = Matrix3::identity();
                            h.add(values, vars, vertex, vertex, &m, lam * l / radius);
                        }
                    }
                }
            }
            if values.iter().all(|v| v.is_finite()) {
                Ok(())
            } else {
                Err(EvalError::Domain("non-finite Hessian".into()))
            }
        })
    }

    fn constraint_name(&self, row: usize) -> String {
        match self.rows.get(row) {
            Some(Row::Curvature { vertex, surface }) => format!(
                "curvature at vertex {vertex} of surface `{}`",
                self.start.surfaces()[*surface]
            ),
            Some(Row::Volume(k)) => format!("volume of `{}`", self.volumes[*k].name),
            Some(Row::Chord(k)) => format!(
                "chord {k} between vertices {} and {}",
                self.chords[*k].a, self.chords[*k].b
            ),
            Some(Row::Guide { vertex, equation }) => {
                format!("guide equation {equation} of vertex {vertex}")
            }
            Some(Row::Rigid(k)) => format!("rigid-motion gauge {k}"),
            None => format!("c[{row}]"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators::{self, Shape};
    use crate::cmc::mesh::Guide;
    use crate::cmc::octahedron::{self, OctahedronTopology};
    use crate::solver::derivatives::{
        CheckOptions, FiniteDifferenceOptions, check_derivatives, jittered_start,
    };

    /// The curvature-row problem of a generated shape.
    fn nlp_of(shape: Shape, weight: f64) -> CmcNlp {
        formulated(shape, weight, Formulation::Curvature)
    }

    /// The area problem of a generated shape.
    fn area_nlp_of(shape: Shape, weight: f64) -> CmcNlp {
        formulated(shape, weight, Formulation::Area)
    }

    fn formulated(shape: Shape, weight: f64, formulation: Formulation) -> CmcNlp {
        let volumes = shape
            .volumes
            .into_iter()
            .map(|(name, region, target)| VolumeConstraint::with_target(name, region, target))
            .collect();
        CmcNlp::with_formulation(shape.mesh, volumes, Vec::new(), weight, formulation).unwrap()
    }

    fn assert_derivatives(nlp: &CmcNlp, what: &str) -> f64 {
        let n = nlp.dims().n;
        let x = jittered_start(nlp, 1e-3, 7);
        let report = check_derivatives(nlp, &x, &crate::cmc::check_options(n)).unwrap();
        let first_order = report.gradient.max_error.max(report.jacobian.max_error);
        assert!(report.passed() && first_order < 1e-6, "{what}: {report}");
        first_order
    }

    #[test]
    fn over_relaxation_follows_the_estimated_contraction() {
        // No contraction: no over-relaxation; energy gains falling ×0.64 per round: λ = 0.8,
        // ω = 2 / 1.2; a gain that grows is capped at λ = MAX_CONTRACTION.
        assert_eq!(over_relaxation(1.0, 0.0), 1.0);
        assert!((over_relaxation(1e-4, 0.64e-4) - 2.0 / 1.2).abs() < 1e-12);
        assert_eq!(over_relaxation(1e-4, 2e-4), 2.0 / (2.0 - MAX_CONTRACTION));
    }

    #[test]
    fn icosahedron_start_is_feasible() {
        let mesh = generators::icosphere(0.01, 0, "skin").unwrap();
        let region = Region {
            boundary: vec![(0, 1.0)],
            reference: Point::zeros(),
        };
        let target = region.volume(&mesh);
        let nlp = CmcNlp::new(
            mesh,
            vec![VolumeConstraint::with_target("ball".into(), region, target)],
            Vec::new(),
            0.01,
        )
        .unwrap();
        let d = nlp.dims();
        // 12 curvature rows, the volume and the six rigid-motion gauge rows (free bubble).
        assert_eq!((d.n, d.m), (12 * 3 + 1, 12 + 1 + 6));
        let mut x = vec![0.0; d.n];
        nlp.start(&mut x);
        let (mut f, mut c) = (0.0, vec![0.0; d.m]);
        nlp.eval(&x, &mut f, &mut c).unwrap();
        assert!(c.iter().all(|v| v.abs() < 1e-12), "{c:?}");
        // A regular mesh has every vertex at its ring centroid's tangent: no regularization.
        assert!(nlp.regularization(&x) < 1e-28);
        let h = nlp.surface_curvatures(&x)[0].unwrap();
        assert!(h > 0.0 && (h * 0.01 - 1.0).abs() < 0.2, "{h}");
    }

    #[test]
    fn derivatives_match_on_every_generator() {
        let shapes = [
            (
                "double bubble",
                generators::double_bubble([1e-6, 2e-6], 2).unwrap(),
            ),
            (
                "triple bubble",
                generators::triple_bubble([1.0, 1.5, 2.0], 2).unwrap(),
            ),
            (
                "cube frame",
                generators::cube_frame(1.0, Some(0.05), 2).unwrap(),
            ),
            (
                "octahedron",
                octahedron::octahedron_frame(1.0, OctahedronTopology::Cone, 3).unwrap(),
            ),
            ("u wires", generators::u_wires(1.0, 0.6, 4).unwrap()),
        ];
        for (what, shape) in shapes {
            let area = area_nlp_of(shape.clone(), 0.05);
            assert_eq!(area.curvature_rows(), 0, "{what}");
            assert_derivatives(&area, what);
            assert_derivatives(&formulated(shape.clone(), 0.05, Formulation::Normal), what);
            let nlp = nlp_of(shape, 0.05);
            assert!(nlp.curvature_rows() > 0, "{what}");
            assert_derivatives(&nlp, what);
        }
    }

    /// The Lagrangian Hessian against central differences of the exact gradient and Jacobian,
    /// column by column (the checker also reports entries missing from the pattern).
    fn assert_hessian(nlp: &CmcNlp, what: &str) {
        let x = jittered_start(nlp, 1e-3, 5);
        // Steps of about 1e-6 in scaled units (edges are 0.1–0.5): the default 1e-4 steps leave
        // a truncation error of order 1e-5 on the curvature rows' third derivatives.
        let options = CheckOptions {
            differences: FiniteDifferenceOptions {
                characteristic_scale: Some(0.02),
                ..FiniteDifferenceOptions::default()
            },
            ..CheckOptions::default()
        };
        let report = check_derivatives(nlp, &x, &options).unwrap();
        let hessian = report.hessian.clone().unwrap();
        assert!(report.scanned_outside_pattern, "{what}: too large to scan");
        assert!(report.passed() && hessian.failed == 0, "{what}: {report}");
        eprintln!(
            "{what}: n = {}, {} Hessian entries checked, max error {:.2e}",
            report.n, hessian.checked, hessian.max_error
        );
    }

    #[test]
    fn lagrangian_hessian_matches_central_differences() {
        let shapes = [
            (
                "double bubble",
                generators::double_bubble([1e-6, 2e-6], 1).unwrap(),
            ),
            (
                "triple bubble",
                generators::triple_bubble([1.0, 1.5, 2.0], 2).unwrap(),
            ),
            (
                "cube frame",
                generators::cube_frame(1.0, Some(0.05), 2).unwrap(),
            ),
            ("u wires", generators::u_wires(1.0, 0.6, 4).unwrap()),
        ];
        for (what, shape) in shapes {
            assert_hessian(&area_nlp_of(shape.clone(), 0.05), what);
            assert_hessian(&formulated(shape.clone(), 0.05, Formulation::Normal), what);
            assert_hessian(&nlp_of(shape, 0.05), what);
        }
        // The smaller bubble at a prescribed pressure (1/m): the −p·V term of the objective.
        let shape = generators::double_bubble([1e-6, 2e-6], 1).unwrap();
        let mut volumes: Vec<VolumeConstraint> = shape
            .volumes
            .into_iter()
            .map(|(name, region, target)| VolumeConstraint::with_target(name, region, target))
            .collect();
        volumes[0].pressure = Some(300.0);
        let nlp =
            CmcNlp::with_formulation(shape.mesh, volumes, Vec::new(), 0.05, Formulation::Area)
                .unwrap();
        assert_eq!(nlp.dims().m, 1 + 6, "one volume row and the rigid gauge");
        assert_derivatives(&nlp, "double bubble at a pressure");
        assert_hessian(&nlp, "double bubble at a pressure");
    }

    /// Diagnostic: eigenvalues of the Lagrangian Hessian reduced to the null space of the
    /// constraint Jacobian at the point a BFGS solve of the cube frame (resolution 2) reaches,
    /// with its multipliers (second-order sufficiency needs them positive).
    /// `cargo test --release --lib reduced_hessian -- --ignored --nocapture`
    #[test]
    #[ignore = "diagnostic: prints the reduced Hessian spectrum"]
    fn reduced_hessian_spectrum_at_a_solved_frame() {
        use crate::solver::{HessianMode, Options, hessian::assemble_dense};
        use nalgebra::{DMatrix, DVector};
        let nlp = nlp_of(generators::cube_frame(0.05, Some(1e-6), 2).unwrap(), 0.01);
        let options = Options {
            hessian: HessianMode::Bfgs,
            ..Options::default()
        };
        let sol = crate::solver::solve(&nlp, &options);
        let d = nlp.dims();
        let (mut rows, mut cols) = (vec![0; d.hess_nnz], vec![0; d.hess_nnz]);
        nlp.hessian_structure(&mut rows, &mut cols);
        let (mut grad, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
        nlp.eval_derivatives(&sol.x, &mut grad, &mut jac).unwrap();
        let mut a = DMatrix::zeros(d.m, d.n);
        for (&(r, c), v) in nlp.structure.pattern.iter().zip(&jac) {
            a[(r, c)] += v;
        }
        // Null space of A: eigenvectors of AᵀA with negligible eigenvalues.
        let ata = (a.transpose() * &a).symmetric_eigen();
        let top = ata.eigenvalues.amax();
        let null: Vec<usize> = (0..d.n)
            .filter(|&k| ata.eigenvalues[k] < 1e-12 * top)
            .collect();
        let z = DMatrix::from_columns(
            &null
                .iter()
                .map(|&k| ata.eigenvectors.column(k))
                .collect::<Vec<_>>(),
        );
        // Stationarity of the Lagrangian with the returned multipliers.
        let mut gl = DVector::from_column_slice(&grad);
        gl += a.transpose() * DVector::from_column_slice(&sol.lambda);
        for sign in [1.0, -1.0] {
            let lambda: Vec<f64> = sol.lambda.iter().map(|l| sign * l).collect();
            let mut values = vec![0.0; d.hess_nnz];
            nlp.eval_hessian(&sol.x, 1.0, &lambda, &mut values).unwrap();
            let h = assemble_dense(d.n, &rows, &cols, &values);
            let reduced = z.transpose() * &h * &z;
            let mut eig: Vec<f64> = reduced.symmetric_eigenvalues().iter().copied().collect();
            eig.sort_by(f64::total_cmp);
            let negative = eig.iter().filter(|&&e| e < 0.0).count();
            eprintln!(
                "λ sign {sign}: status {:?}, {} iterations, n = {}, null space {}, |∇L| = {:.2e}, \
                 reduced eigenvalues {:.3e} … {:.3e}, {negative} negative",
                sol.status,
                sol.iterations,
                d.n,
                null.len(),
                gl.amax(),
                eig[0],
                eig[eig.len() - 1]
            );
        }
        assert!(sol.constraints.iter().all(|c| c.abs() < 1e-6));
    }

    #[test]
    fn guides_and_chords_have_exact_derivatives() {
        let mut mesh = generators::icosphere(2.0, 1, "skin").unwrap();
        let plane = mesh.add_guide(Guide::Plane {
            point: Point::new(0.0, 0.0, 0.0),
            normal: Point::new(0.3, 1.0, 0.0),
        });
        let circle = mesh.add_guide(Guide::Circle {
            centre: Point::new(0.0, 1.0, 0.0),
            axis: Point::new(0.0, 1.0, 0.2),
            radius: 1.5,
        });
        let line = mesh.add_guide(Guide::Line {
            point: Point::new(1.0, 0.0, 0.0),
            direction: Point::new(0.0, 0.0, 1.0),
        });
        for (v, g) in [(3, plane), (5, circle), (8, line)] {
            let mut f = mesh.flags()[v];
            f.guide = Some(g);
            mesh.set_flags(v, f).unwrap();
        }
        let mut f = mesh.flags()[0];
        f.fixed = true;
        mesh.set_flags(0, f).unwrap();
        let chords = vec![
            Chord {
                a: 0,
                b: 9,
                length: 3.0,
            },
            Chord {
                a: 4,
                b: 7,
                length: 1.0,
            },
        ];
        for formulation in [Formulation::Curvature, Formulation::Area] {
            let nlp = CmcNlp::with_formulation(
                mesh.clone(),
                Vec::new(),
                chords.clone(),
                0.1,
                formulation,
            )
            .unwrap();
            // 42 vertices, 1 fixed, 3 guided: 38 curvature rows (curvature formulation only),
            // 2 chords, 1 + 2 + 2 guide rows.
            let curvature_rows = if formulation == Formulation::Area {
                0
            } else {
                38
            };
            assert_eq!(nlp.dims().m, curvature_rows + 2 + 5);
            assert_derivatives(&nlp, "guides and chords");
            assert_hessian(&nlp, "guides and chords");
        }
    }

    #[test]
    fn normal_coordinates_give_one_column_per_surface_vertex_and_converge_in_rounds() {
        let shape = generators::double_bubble([1e-6, 2e-6], 4).unwrap();
        let mesh = shape.mesh.clone();
        let mut cartesian = formulated(shape.clone(), 0.01, Formulation::Area);
        let mut nlp = formulated(shape, 0.01, Formulation::Normal);
        let interior = (0..mesh.vertex_count())
            .filter(|&v| mesh.curvature_surface(v).is_some())
            .count();
        let others = mesh.vertex_count() - interior;
        // The others are the junction circle's 24 vertices (two junction edges, 15° turns):
        // each moves in the plane normal to the circle.
        assert_eq!(others, 24);
        assert_eq!(nlp.dims().n, interior + 2 * others);
        // Two volume rows and the translation gauge (no rotation rows in normal coordinates).
        assert_eq!(nlp.dims().m, 2 + 3);
        assert_derivatives(&nlp, "double bubble, junction planes");
        assert_hessian(&nlp, "double bubble, junction planes");
        let options = Options {
            verbosity: 0,
            ..Options::default()
        };
        let solution = nlp.solve(&options, "");
        assert!(solution.status.is_success(), "{:?}", solution.status);
        let mesh = nlp.mesh_at(&solution.x).unwrap();
        let area = total_area(&mesh);
        // Same mesh in Cartesian coordinates; the relaxation between rounds brings the normal
        // coordinates to its area (without it: 1.1e-3 relative above, at these 288 triangles).
        let cartesian_solution = cartesian.solve(&options, "");
        let cartesian_area = total_area(&cartesian.mesh_at(&cartesian_solution.x).unwrap());
        let exact = 11.854293128e-4;
        assert!(
            (area / cartesian_area - 1.0).abs() < 1e-4,
            "{area} {cartesian_area}"
        );
        assert!(area > exact && area < exact * 1.02, "{area}");
        for (body, target) in nlp.volumes().iter().zip([1e-6, 2e-6]) {
            assert!((body.region.volume(&mesh) - target).abs() < 1e-9 * target);
        }
    }

    #[test]
    fn normal_rounds_with_tangential_relaxation_reach_the_area_formulations_minimum() {
        // Generated starts whose tangential layout is not the minimum's: the cube frame film's
        // planar walls (junction lines travel) and the double bubble. Without relaxation the
        // rounds end 1e-3 above the area formulation's area (+0.06…0.08 % on the cube film).
        let options = Options {
            verbosity: 0,
            ..Options::default()
        };
        let cases = [
            (generators::cube_frame(0.05, None, 4).unwrap(), 1.0),
            (generators::double_bubble([1e-6, 2e-6], 4).unwrap(), 0.01),
        ];
        for (shape, weight) in cases {
            let mut cartesian = formulated(shape.clone(), weight, Formulation::Area);
            let cartesian_solution = cartesian.solve(&options, "");
            assert!(cartesian_solution.status.is_success());
            let cartesian_area = total_area(&cartesian.mesh_at(&cartesian_solution.x).unwrap());
            let mut nlp = formulated(shape, weight, Formulation::Normal).with_rounds(80, 0.0);
            let solution = nlp.solve(&options, "");
            assert!(solution.status.is_success(), "{:?}", solution.status);
            assert_eq!(nlp.formulation(), Formulation::Normal, "no fall-back");
            let area = total_area(&nlp.mesh_at(&solution.x).unwrap());
            assert!(
                (area / cartesian_area - 1.0).abs() < 1e-5,
                "normal {area}, area formulation {cartesian_area}"
            );
        }
    }

    #[test]
    fn degenerate_points_are_domain_errors() {
        let nlp = nlp_of(generators::u_wires(1.0, 0.6, 4).unwrap(), 0.0);
        let mut x = vec![0.0; nlp.dims().n];
        nlp.start(&mut x);
        let (mut f, mut c) = (0.0, vec![0.0; nlp.dims().m]);
        x[0] = f64::NAN;
        assert!(matches!(
            nlp.eval(&x, &mut f, &mut c),
            Err(EvalError::Domain(_))
        ));
        // Collapse every free vertex onto one point: zero-area triangles.
        let k = nlp.dims().n - nlp.curvature_column.iter().flatten().count();
        x[..k].fill(0.0);
        assert!(matches!(
            nlp.eval(&x, &mut f, &mut c),
            Err(EvalError::Domain(_))
        ));
    }
}
