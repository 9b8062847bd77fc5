//! References for the `linear` mass option: the plastic layout-optimization LP on a fixed ground
//! structure, and Michell's closed-form optimal volumes.
//!
//! Plastic layout LP (Dorn, Gomory & Greenberg 1964; Gilbert & Tyas 2003), for one load case:
//! ```text
//!     min  Σ_j L_j·(t_j/σ_T + c_j/σ_C)     (volume, m³)
//!     s.t. Σ_j ±(c_j − t_j)·r·e_j = −r·f_i   for every balance direction r of every joint i
//!          t, c ≥ 0
//! ```
//! with λ = c − t (compression positive), the same balance directions and sign convention as the
//! NLP (supports take the rest), and no self-weight. Mass = ρ·volume.
//!
//! Michell closed forms (σ in Pa, P in N, lengths in m; volumes in m³):
//! - circle-supported cantilever: a point load P at distance L from the centre of a rigid circle
//!   of radius r, perpendicular to the radius, σ_T = σ_C = σ: V* = 2·P·L·ln(L/r)/σ;
//! - half-wheel: simple supports at (±a, 0) (pinned at −a, roller with a vertical reaction at
//!   +a), a load P at (0, 0) along −y, material in y ≥ 0: V* = π·P·a/σ (a semicircular
//!   compression rim, whose end forces are vertical, and radial tension spokes, both carrying
//!   P/2). With both supports pinned the optimum is lower (horizontal thrust is free).

use nalgebra::DMatrix;
use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};

use super::lp::{self, LpError};
use super::mass::gravity;
use super::model::{Structure, Vec3};
use super::nlp::balance_basis;
use super::simplex::{self, Basic};
use crate::solver::Interrupt;

/// The LP optimum on a fixed ground structure.
#[derive(Debug, Clone, PartialEq)]
pub struct PlasticLayout {
    /// Optimal volume, m³.
    pub volume: f64,
    /// Beam forces λ = c − t, N (+ compression).
    pub forces: Vec<f64>,
    /// Virtual displacements (the LP duals), one per balance row.
    pub duals: Vec<f64>,
    /// The dual objective, m³ (equals `volume` at a certified optimum).
    pub dual_volume: f64,
    /// Largest equilibrium residual of the LP solution, N.
    pub primal_residual: f64,
    /// Largest dual-constraint violation, m³/N.
    pub dual_infeasibility: f64,
}

/// How the layout LP is solved ([`super::lp`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LpMethod {
    /// The dense two-phase simplex method: a vertex solution, for small reference problems.
    Simplex,
    /// The sparse interior-point method with a crossover to a vertex, for whole ground
    /// structures.
    InteriorPoint,
    /// The sparse interior-point method alone: a point of the optimal face (its forces spread
    /// over tied members), for member adding on thousands of members.
    InteriorFace,
}

/// Solves the plastic layout LP (module header) for load case `case` by the dense simplex
/// method (the reference); `planar` restricts balance to x and y.
pub fn layout(
    structure: &Structure,
    case: usize,
    planar: bool,
    sigma_t: f64,
    sigma_c: f64,
) -> Result<PlasticLayout, LpError> {
    let costs: Vec<(f64, f64)> = (0..structure.beams.len())
        .map(|j| {
            let length = structure.length(j);
            (length / sigma_t, length / sigma_c)
        })
        .collect();
    let axes = if planar { 2 } else { 3 };
    let interrupt = Interrupt::new();
    layout_with_costs(
        structure,
        case,
        axes,
        &costs,
        None,
        LpMethod::Simplex,
        &interrupt,
    )
}

/// The layout LP with general per-beam costs: `costs[j] = (cost per newton of tension, cost per
/// newton of compression)` of beam j (any unit; `volume` is in that unit times N), balance in
/// the first `axes` coordinate directions, solved by `method` until `interrupt` is raised.
///
/// `self_weight[j] = (kg per newton of tension, kg per newton of compression)` of beam j, if
/// given: the beam's weight `g·(w_T·t_j + w_C·c_j)` is lumped half on each end, as in the NLP's
/// balance rows (seed eq. 4.1). It is linear in the forces, so the problem stays an LP.
pub fn layout_with_costs(
    structure: &Structure,
    case: usize,
    axes: usize,
    costs: &[(f64, f64)],
    self_weight: Option<&[(f64, f64)]>,
    method: LpMethod,
    interrupt: &Interrupt,
) -> Result<PlasticLayout, LpError> {
    let LayoutLp { a, b, cost } = layout_lp(structure, case, axes, costs, self_weight);
    let s = match method {
        LpMethod::Simplex => lp::solve(&DMatrix::from(&a), &b, &cost, interrupt)?,
        LpMethod::InteriorPoint => {
            lp::solve_sparse(&CsrMatrix::from(&a), &b, &cost, true, interrupt)?
        }
        LpMethod::InteriorFace => {
            lp::solve_sparse(&CsrMatrix::from(&a), &b, &cost, false, interrupt)?
        }
    };
    Ok(layout_of(structure.beams.len(), &b, s))
}

/// [`layout_with_costs`] by the revised simplex method ([`simplex::solve`]) from the basis
/// `warm` if it is usable for this LP (columns as in [`LayoutLp`]), with the optimal basis: a
/// vertex, for member adding's intermediate LPs.
pub fn layout_by_simplex(
    structure: &Structure,
    case: usize,
    axes: usize,
    costs: &[(f64, f64)],
    self_weight: Option<&[(f64, f64)]>,
    warm: Option<&[Basic]>,
    interrupt: &Interrupt,
) -> Result<(PlasticLayout, Vec<Basic>), LpError> {
    let LayoutLp { a, b, cost } = layout_lp(structure, case, axes, costs, self_weight);
    let solved = simplex::solve(&CscMatrix::from(&a), &b, &cost, warm, interrupt)?;
    let layout = layout_of(structure.beams.len(), &b, solved.solution);
    Ok((layout, solved.basis))
}

/// Reduced cost above which (relative to the column's cost) a column is off the optimal face
/// in [`layout_on_face`]: far above the rounding of an optimal vertex's reduced costs
/// (≲ 1e-14 on the scaled layout LPs), far below any real price difference.
pub const FACE_TOLERANCE: f64 = 1e-9;

/// The primal solution of the layout LP `lp` ([`layout_lp`]) by the interior point without
/// crossover (as [`LpMethod::InteriorFace`]), from an optimal vertex `vertex` of that LP and its
/// basis `basis` ([`layout_by_simplex`]).
///
/// The columns whose reduced cost c_j − a_jᵀy under the vertex's duals y exceeds
/// [`FACE_TOLERANCE`]·c_j are zero in every optimal solution (complementary slackness); the
/// others span the optimal face. When they are all basic, their columns are independent and
/// the face is the vertex alone, the LP's only optimum, which the interior point on the whole
/// LP would approach to its tolerance: it is returned as it is. Otherwise the interior point
/// solves the LP on those columns and the rows they reach (the other rows are unloaded, else y
/// is not optimal: [`LpError::Infeasible`]), whose optimal set is the whole LP's: a point of
/// the face's relative interior, forces spread over tied members, at a fraction of the cost
/// (not the same point as on the whole LP: Mehrotra's iterates stop short of the face's
/// analytic centre, where the path left them). Forces are zero off the face; duals and dual
/// figures are the vertex's.
pub fn layout_on_face(
    lp: &LayoutLp,
    vertex: &PlasticLayout,
    basis: &[Basic],
    interrupt: &Interrupt,
) -> Result<PlasticLayout, LpError> {
    let (b, cost) = (&lp.b, &lp.cost);
    let a = CscMatrix::from(&lp.a);
    let (m, n) = (a.nrows(), a.ncols());
    let mut basic = vec![false; n];
    for &k in basis {
        if let Basic::Column(j) = k {
            basic[j] = true;
        }
    }
    let mut columns = Vec::new();
    let mut row_used = vec![false; m];
    for (j, &c) in cost.iter().enumerate() {
        let col = a.col(j);
        let aty: f64 = (col.row_indices().iter().zip(col.values()))
            .map(|(&r, &v)| v * vertex.duals[r])
            .sum();
        if c - aty <= FACE_TOLERANCE * c.abs() {
            columns.push(j);
            col.row_indices().iter().for_each(|&r| row_used[r] = true);
        }
    }
    if columns.iter().all(|&j| basic[j]) {
        return Ok(vertex.clone());
    }
    let mut row_of = vec![usize::MAX; m];
    let mut rows = Vec::new();
    for r in 0..m {
        if row_used[r] {
            row_of[r] = rows.len();
            rows.push(r);
        } else if b[r] != 0.0 {
            return Err(LpError::Infeasible);
        }
    }
    let mut face = CooMatrix::new(rows.len(), columns.len());
    for (k, &j) in columns.iter().enumerate() {
        let col = a.col(j);
        for (&r, &v) in col.row_indices().iter().zip(col.values()) {
            face.push(row_of[r], k, v);
        }
    }
    let face_b: Vec<f64> = rows.iter().map(|&r| b[r]).collect();
    let face_cost: Vec<f64> = columns.iter().map(|&j| cost[j]).collect();
    let s = lp::solve_sparse(
        &CsrMatrix::from(&face),
        &face_b,
        &face_cost,
        false,
        interrupt,
    )?;
    let mut x = vec![0.0; n];
    for (k, &j) in columns.iter().enumerate() {
        x[j] = s.x[k];
    }
    let beams = n / 2;
    Ok(PlasticLayout {
        volume: s.objective,
        forces: (0..beams).map(|j| x[j] - x[beams + j]).collect(),
        primal_residual: s.primal_residual,
        ..vertex.clone()
    })
}

/// The layout of an LP solution over `beams` beams with right-hand side `b`.
fn layout_of(beams: usize, b: &[f64], s: lp::LpSolution) -> PlasticLayout {
    let forces = (0..beams).map(|j| s.x[j] - s.x[beams + j]).collect();
    let dual_volume = s.y.iter().zip(b).map(|(y, b)| y * b).sum();
    PlasticLayout {
        volume: s.objective,
        forces,
        duals: s.y,
        dual_volume,
        primal_residual: s.primal_residual,
        dual_infeasibility: s.dual_infeasibility,
    }
}

/// The layout LP in standard form `min costᵀx s.t. A x = b, x ≥ 0` (module header).
#[derive(Debug, Clone)]
pub struct LayoutLp {
    /// Balance rows (each joint's balance directions in joint order) by columns: column j is
    /// beam j's compression c_j, column `beams + j` its tension t_j.
    pub a: CooMatrix<f64>,
    /// Minus the loads along each row's direction, N.
    pub b: Vec<f64>,
    /// Cost per newton of each column (the unit of `costs`).
    pub cost: Vec<f64>,
}

/// The LP that [`layout_with_costs`] solves (same arguments), without solving it.
pub fn layout_lp(
    structure: &Structure,
    case: usize,
    axes: usize,
    costs: &[(f64, f64)],
    self_weight: Option<&[(f64, f64)]>,
) -> LayoutLp {
    let beams = structure.beams.len();
    let mut rows: Vec<(usize, nalgebra::Vector3<f64>)> = Vec::new();
    let mut first_row = Vec::with_capacity(structure.joints.len());
    for (i, joint) in structure.joints.iter().enumerate() {
        first_row.push(rows.len());
        for r in balance_basis(&joint.kind, axes) {
            rows.push((i, r));
        }
    }
    first_row.push(rows.len());
    let mut a = CooMatrix::new(rows.len(), 2 * beams);
    let mut cost = vec![0.0; 2 * beams];
    for (j, beam) in structure.beams.iter().enumerate() {
        let length = structure.length(j);
        let [p, q] = beam.ends;
        let e = (structure.joints[q].position - structure.joints[p].position) / length;
        for (end, sign) in [(p, -1.0), (q, 1.0)] {
            for (row, (_, direction)) in rows
                .iter()
                .enumerate()
                .take(first_row[end + 1])
                .skip(first_row[end])
            {
                let v = sign * direction.dot(&e);
                // Column j: compression c_j (λ = +c); column beams + j: tension t_j (λ = −t).
                // Duplicate entries (a beam joining a joint to itself cannot occur) would sum.
                let (w_t, w_c) = self_weight.map_or((0.0, 0.0), |w| w[j]);
                let half_weight = 0.5 * direction.dot(&gravity());
                a.push(row, j, v + half_weight * w_c);
                a.push(row, beams + j, -v + half_weight * w_t);
            }
        }
        cost[j] = costs[j].1;
        cost[beams + j] = costs[j].0;
    }
    let b: Vec<f64> = rows
        .iter()
        .map(|(i, r)| -r.dot(&structure.joints[*i].loads[case]))
        .collect();
    LayoutLp { a, b, cost }
}

/// Virtual displacements of the joints from the duals of [`layout_with_costs`] (same `axes`):
/// u_i = Σ_r y_r·r over joint i's balance directions r, zero at a pinned anchor (dual units:
/// cost per newton).
pub fn virtual_displacements(structure: &Structure, axes: usize, duals: &[f64]) -> Vec<Vec3> {
    let mut row = 0;
    (structure.joints.iter())
        .map(|joint| {
            let mut u = Vec3::zeros();
            for r in balance_basis(&joint.kind, axes) {
                u += duals[row] * r;
                row += 1;
            }
            u
        })
        .collect()
}

/// Michell's circle-supported cantilever: V* = 2·P·L·ln(L/r)/σ, m³.
pub fn michell_cantilever_volume(load: f64, distance: f64, radius: f64, sigma: f64) -> f64 {
    2.0 * load * distance * (distance / radius).ln() / sigma
}

/// Michell's half-wheel: V* = π·P·a/σ, m³.
pub fn michell_half_wheel_volume(load: f64, half_span: f64, sigma: f64) -> f64 {
    std::f64::consts::PI * load * half_span / sigma
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::truss::model::{Beam, Joint, JointKind, Support, Vec3};

    fn joint(x: f64, y: f64, kind: JointKind, load: Vec3) -> Joint {
        Joint {
            position: Vec3::new(x, y, 0.0),
            kind,
            name: None,
            loads: vec![load],
        }
    }

    #[test]
    fn two_bar_truss_volume_is_the_hand_value() {
        // Anchors (±3, 0), load P down at (0, 4): two bars of length 5 in compression P·5/8.
        let p = 1e5;
        let s = Structure {
            joints: vec![
                joint(-3.0, 0.0, JointKind::Anchor(Support::Pinned), Vec3::zeros()),
                joint(3.0, 0.0, JointKind::Anchor(Support::Pinned), Vec3::zeros()),
                joint(0.0, 4.0, JointKind::Load, Vec3::new(0.0, -p, 0.0)),
            ],
            beams: vec![Beam::new(0, 2), Beam::new(1, 2)],
        };
        let sol = layout(&s, 0, true, 200e6, 100e6).unwrap();
        let expected = 2.0 * 5.0 * (p * 5.0 / 8.0) / 100e6;
        assert!((sol.volume - expected).abs() < 1e-12 * expected);
        assert!((sol.dual_volume - sol.volume).abs() < 1e-9 * expected);
        assert!(sol.forces.iter().all(|f| (f - p * 5.0 / 8.0).abs() < 1e-6));
    }

    #[test]
    fn self_weight_adds_half_the_hangers_weight_to_its_load() {
        // A hanger of length 2 m from an anchor at (0, 2) down to a load P at (0, 0): its
        // tension t carries P and half its own weight g·w·t, so t = P/(1 − g·w/2) for w kg per
        // newton; the cost counts t.
        let p = 1e5;
        let w = 2.0 * 7850.0 / 250e6;
        let s = Structure {
            joints: vec![
                joint(0.0, 2.0, JointKind::Anchor(Support::Pinned), Vec3::zeros()),
                joint(0.0, 0.0, JointKind::Load, Vec3::new(0.0, -p, 0.0)),
            ],
            beams: vec![Beam::new(0, 1)],
        };
        let method = LpMethod::Simplex;
        let sol = layout_with_costs(
            &s,
            0,
            2,
            &[(1.0, 1.0)],
            Some(&[(w, w)]),
            method,
            &Interrupt::new(),
        )
        .unwrap();
        let t = p / (1.0 - 0.5 * crate::truss::mass::STANDARD_GRAVITY * w);
        assert!(
            (sol.forces[0] + t).abs() < 1e-9 * t,
            "{} vs {}",
            -sol.forces[0],
            t
        );
        assert!((sol.volume - t).abs() < 1e-9 * t);
        let light =
            layout_with_costs(&s, 0, 2, &[(1.0, 1.0)], None, method, &Interrupt::new()).unwrap();
        assert!((light.forces[0] + p).abs() < 1e-9 * p);
    }

    /// Fully connected planar ground structure on a grid, load and supports among its nodes.
    fn grid(nx: usize, ny: usize, h: f64, x0: f64) -> Vec<Vec3> {
        let mut points = Vec::new();
        for i in 0..nx {
            for k in 0..ny {
                points.push(Vec3::new(x0 + i as f64 * h, k as f64 * h, 0.0));
            }
        }
        points
    }

    /// The half-wheel ground structure: supports at (±1, 0) (west pinned, east `east`), the
    /// load `load` at (0, 0), nodes in y ≥ 0 on a 0.25 grid, all pairs connected except
    /// overlapping collinear ones.
    fn half_wheel_ground(east: Support, load: Vec3) -> Structure {
        let joints: Vec<Joint> = grid(9, 5, 0.25, -1.0)
            .iter()
            .map(|q| {
                let kind = if q.y == 0.0 && q.x == -1.0 {
                    JointKind::Anchor(Support::Pinned)
                } else if q.y == 0.0 && q.x == 1.0 {
                    JointKind::Anchor(east.clone())
                } else if q.norm() == 0.0 {
                    JointKind::Load
                } else {
                    JointKind::Free
                };
                let at = if q.norm() == 0.0 { load } else { Vec3::zeros() };
                joint(q.x, q.y, kind, at)
            })
            .collect();
        let beams = crate::truss::ground::connect(
            &joints,
            joints.len(),
            &Default::default(),
            &[],
            &[],
            1e-9,
        );
        Structure { joints, beams }
    }

    #[test]
    fn half_wheel_lp_approaches_michell_from_above() {
        // Simple supports at (±1, 0), P at (0, 0), nodes in y ≥ 0 on a 0.25 grid; all pairs
        // connected except overlapping collinear ones.
        let (p, a, sigma) = (1.0, 1.0, 1.0);
        let s = half_wheel_ground(Support::Roller(vec![Vec3::y()]), Vec3::new(0.0, -p, 0.0));
        let sol = layout(&s, 0, true, sigma, sigma).unwrap();
        let exact = michell_half_wheel_volume(p, a, sigma);
        println!(
            "half-wheel LP volume {} (Michell {exact}), {} bars",
            sol.volume,
            s.beams.len()
        );
        assert!(
            sol.primal_residual < 1e-9 && sol.dual_infeasibility < 1e-9,
            "{sol:?}"
        );
        assert!(
            (sol.dual_volume - sol.volume).abs() < 1e-8 * exact,
            "certified: primal {} dual {} exact {exact}",
            sol.volume,
            sol.dual_volume
        );
        assert!(
            sol.volume >= exact * (1.0 - 1e-9),
            "{} < {exact}",
            sol.volume
        );
        assert!(sol.volume <= 1.03 * exact, "{} vs {exact}", sol.volume);
    }

    #[test]
    fn interior_point_with_crossover_matches_the_simplex() {
        // The half-wheel ground structure of the test above, both solvers; unequal strengths so
        // that tension and compression columns differ.
        let s = half_wheel_ground(Support::Pinned, Vec3::new(0.3, -1.0, 0.0));
        let costs: Vec<(f64, f64)> = (0..s.beams.len())
            .map(|j| (s.length(j) / 2.0, s.length(j)))
            .collect();
        let simplex =
            layout_with_costs(&s, 0, 2, &costs, None, LpMethod::Simplex, &Interrupt::new())
                .unwrap();
        let interior = layout_with_costs(
            &s,
            0,
            2,
            &costs,
            None,
            LpMethod::InteriorPoint,
            &Interrupt::new(),
        )
        .unwrap();
        let gap = (interior.volume - simplex.volume).abs() / simplex.volume;
        assert!(gap < 1e-6, "{} vs {}", interior.volume, simplex.volume);
        assert!(interior.primal_residual < 1e-9, "{interior:?}");
        assert!(interior.dual_infeasibility < 1e-9, "{interior:?}");
        assert!((interior.dual_volume - interior.volume).abs() < 1e-6 * simplex.volume);
        // A vertex: at most one member per balance row carries force.
        let rows = 2 * (s.joints.len() - 2);
        let active = interior.forces.iter().filter(|f| f.abs() > 1e-9).count();
        assert!(active <= rows, "{active} members on {rows} rows");
    }

    /// The planar layout LP of `s` three ways: by the interior point on the whole LP, by the
    /// revised simplex (a vertex) and by the interior point on that vertex's optimal face.
    fn three_ways(s: &Structure, costs: &[(f64, f64)]) -> [PlasticLayout; 3] {
        let interrupt = Interrupt::new();
        let whole =
            layout_with_costs(s, 0, 2, costs, None, LpMethod::InteriorFace, &interrupt).unwrap();
        let (vertex, basis) = layout_by_simplex(s, 0, 2, costs, None, None, &interrupt).unwrap();
        let lp = layout_lp(s, 0, 2, costs, None);
        let face = layout_on_face(&lp, &vertex, &basis, &interrupt).unwrap();
        [whole, vertex, face]
    }

    #[test]
    fn the_interior_point_on_the_vertex_face_matches_it_on_the_whole_lp() {
        // Half-wheel ground structures (a regular grid: dual ties) under several loads and
        // strength ratios, two with joints displaced; at least one optimum is a single vertex.
        let mut single = 0;
        for (k, (load, ratio, jitter)) in [
            (Vec3::new(0.0, -1.0, 0.0), 1.0, 0.0),
            (Vec3::new(0.3, -1.0, 0.0), 0.5, 0.0),
            (Vec3::new(-0.7, -0.2, 0.0), 2.0, 0.0),
            (Vec3::new(0.3, -1.0, 0.0), 0.5, 1e-3),
            (Vec3::new(0.0, -1.0, 0.0), 1.0, 1e-3),
        ]
        .into_iter()
        .enumerate()
        {
            let mut s = half_wheel_ground(Support::Roller(vec![Vec3::y()]), load);
            for (i, joint) in s.joints.iter_mut().enumerate() {
                let wobble = jitter * ((i * 7919 + k) % 13) as f64 / 13.0;
                joint.position += Vec3::new(wobble, -0.5 * wobble, 0.0);
            }
            let costs: Vec<(f64, f64)> = (0..s.beams.len())
                .map(|j| (ratio * s.length(j), s.length(j)))
                .collect();
            let [whole, vertex, face] = three_ways(&s, &costs);
            let scale = whole.volume;
            assert!(
                (face.volume - whole.volume).abs() < 1e-9 * scale,
                "case {k}"
            );
            assert!(
                face.primal_residual < 1e-9,
                "case {k}: {}",
                face.primal_residual
            );
            assert_eq!(face.duals, vertex.duals);
            let largest = whole.forces.iter().fold(0.0, |a: f64, f| a.max(f.abs()));
            let gap = (whole.forces.iter().zip(&face.forces))
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(gap < 1e-5 * largest, "case {k}: forces differ by {gap}");
            single += usize::from(face == vertex);
        }
        assert!(single > 0, "no optimum was a single vertex");
        // A tie: a hanger from the anchor (0, 1) to the load P at (0, 0), and a chain of two
        // halves through the free joint (0, ½), braced by an idle bar to the anchor (1, ½). The
        // vertex hangs P on one path; the interior point, on the face as on the whole LP, on
        // both (not in the same split: Mehrotra's iterates stop short of the face's analytic
        // centre, P/3 on the hanger, at a point that depends on the path).
        let p = 1.0;
        let anchor = JointKind::Anchor(Support::Pinned);
        let s = Structure {
            joints: vec![
                joint(0.0, 1.0, anchor.clone(), Vec3::zeros()),
                joint(0.0, 0.0, JointKind::Load, Vec3::new(0.0, -p, 0.0)),
                joint(0.0, 0.5, JointKind::Free, Vec3::zeros()),
                joint(1.0, 0.5, anchor, Vec3::zeros()),
            ],
            beams: vec![
                Beam::new(0, 1),
                Beam::new(1, 2),
                Beam::new(0, 2),
                Beam::new(2, 3),
            ],
        };
        let costs: Vec<(f64, f64)> = (0..4).map(|j| (s.length(j), s.length(j))).collect();
        let [whole, vertex, face] = three_ways(&s, &costs);
        assert!(
            (vertex.forces[0] * vertex.forces[1]).abs() < 1e-12,
            "{vertex:?}"
        );
        for forces in [&whole.forces, &face.forces] {
            assert!((forces[0] + forces[1] + p).abs() < 1e-9, "{forces:?}");
            assert!(forces[0] < -0.2 * p && forces[1] < -0.2 * p, "{forces:?}");
            assert!((forces[1] - forces[2]).abs() < 1e-9 && forces[3].abs() < 1e-9);
        }
        assert!((face.volume - p).abs() < 1e-9 && (whole.volume - p).abs() < 1e-9);
    }

    #[test]
    fn closed_forms() {
        assert!(
            (michell_half_wheel_volume(2.0, 3.0, 4.0) - 1.5 * std::f64::consts::PI).abs() < 1e-15
        );
        let v = michell_cantilever_volume(1.0, std::f64::consts::E, 1.0, 2.0);
        assert!((v - std::f64::consts::E).abs() < 1e-15);
    }
}
