//! Stability of a solved film: the smallest eigenvalues of the second variation of the area
//! under the volume constraints (Surface Evolver's `eigenprobe` / `saddle`).
//!
//! At a solution the energy is the Lagrangian `L = A − Σ p_i V_i`, with the pressures `p_i`
//! (1/m) the least-squares multipliers of `∇A = Σ p_i ∇V_i` on the moving vertices. Its exact
//! Hessian ([`super::area::triangle_area_hessian`], [`super::volume::cone_volume_hessian`]) is
//! restricted to normal motion, as Evolver's `hessian_normal`: one degree of freedom along the
//! area-weighted normal at a vertex inside a surface, the plane across the junction line at a
//! vertex on one (two degrees), all three at other free vertices (points where junction lines
//! meet, free boundaries); fixed and guided vertices do not move. Tangential motion only
//! reparametrizes the surface (a zero mode of the smooth area, a nearly flat direction of the
//! discrete one) and is left out. Each degree of freedom is weighted by the vertex's mixed
//! area `M` (the generalized problem `K u = λ M u`), so the eigenvalues approximate those of
//! the Jacobi operator `−Δ − |II|²` in 1/m², independent of the resolution. The motion is
//! further restricted to keep every volume held at a target (the rows `∇V_i`; a body at a
//! prescribed pressure keeps its `p_i` and restricts nothing) and, for a mesh with no fixed
//! vertex, to be orthogonal to the normal parts of the six rigid motions (which cost nothing).
//!
//! A film is stable when the smallest eigenvalue is positive; a negative one is a direction of
//! descent that the constraints do not forbid: the solution is a saddle (the catenoid's
//! unstable branch, the octahedral cone film).
//!
//! The eigenvalues come from the sparse bordered matrix
//! ```text
//!     [ K − σI   Rᵀ ]      R: the orthonormal restriction rows (b of them)
//!     [ R        0  ]
//! ```
//! which has `b` negative eigenvalues from the border plus one per eigenvalue of K on the allowed
//! motion below σ (Sylvester's law of inertia), so one sparse LDLᵀ ([`crate::solver::kkt`])
//! counts them: at σ = −`NEGATIVE_TOLERANCE` × the spectrum's Gershgorin bound g it gives the
//! number of negative ones, whatever the number reported. Its factors, at a shift below the
//! spectrum, then apply `(P(K − σI)P)⁻¹` to a block of vectors, first a few times alone
//! (subspace iteration), then growing a basis whose Rayleigh–Ritz values on K converge to the
//! smallest eigenvalues (module `shift_invert`) until each is within [`RELATIVE_PRECISION`] ×
//! max(|λ_i|, the largest reported |λ_j|) of an eigenvalue by its residual or Kato–Temple bound
//! (reported as `eigenvalue_errors`); one more count certifies that none was missed. When it
//! cannot certify, bisection on σ brackets each eigenvalue to the same precision (module
//! `slicing`, a factorization per step). Six significant digits of the largest reported value
//! are what a user reads; the earlier target, 1e-10·g, cost more blocks for digits nobody uses.
//! Meshes above [`SPARSE_LIMIT`] degrees of freedom are not analysed.

use nalgebra::{DMatrix, DVector, Matrix3};

use super::area::{area_vector, mixed_area, total_area_gradient, triangle_area_hessian};
use super::mesh::{Mesh, Point};
use super::volume::{Region, cone_volume_hessian};

mod bordered;
mod shift_invert;
mod slicing;

/// Most degrees of freedom analysed at all (spectrum slicing).
pub const SPARSE_LIMIT: usize = 200_000;

/// Precision of a reported eigenvalue λ_i: an eigenvalue of the discrete problem lies within
/// `RELATIVE_PRECISION` × max(|λ_i|, the largest reported |λ_j|) of it (six significant digits
/// of the largest, the same absolute accuracy for the smaller ones, so a value near 0 is not
/// refined for ever), by a residual or Kato–Temple bound ([`Stability::eigenvalue_errors`]).
pub const RELATIVE_PRECISION: f64 = 1e-6;

/// Floor of that precision, relative to the Gershgorin bound g of K (it decides only when
/// every reported eigenvalue is within 1e-4·g of 0).
pub const ABSOLUTE_PRECISION: f64 = 1e-10;

/// Eigenvalues reported by default (`[stability] eigenvalues`).
pub const REPORTED: usize = 6;

/// Negative eigenvalues count when below `−NEGATIVE_TOLERANCE` times the largest magnitude.
pub const NEGATIVE_TOLERANCE: f64 = 1e-8;

/// The stability figures of a solution.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Stability {
    /// Normal degrees of freedom (before the volume and rigid-motion restrictions).
    pub degrees_of_freedom: usize,
    /// The smallest eigenvalues, ascending, 1/m² (empty when not analysed).
    pub smallest_eigenvalues: Vec<f64>,
    /// A bound on the error of each of `smallest_eigenvalues`, 1/m²: an eigenvalue of the
    /// discrete problem lies within it (a residual or Kato–Temple bound, or half a slicing
    /// bracket; at most [`RELATIVE_PRECISION`] × max(|λ_i|, the largest reported |λ_j|)).
    pub eigenvalue_errors: Vec<f64>,
    /// [`RELATIVE_PRECISION`], the precision the eigenvalues were computed to.
    pub relative_precision: f64,
    /// Eigenvalues below −[`NEGATIVE_TOLERANCE`] × the Gershgorin bound of K (its largest
    /// possible magnitude).
    pub negative: usize,
    /// "stable", "saddle" or "not analysed: …".
    pub verdict: String,
    /// Pressures `p_i` of the bodies, 1/m (J/m³ per unit surface tension): prescribed, or
    /// fitted for the held volumes.
    pub pressures: Vec<f64>,
    /// For a saddle: the eigenvector of the smallest eigenvalue as a motion of each vertex
    /// (normal motion, zero at fixed and guided vertices), scaled to a largest displacement of
    /// 1 (dimensionless; multiply by a length). Not written to `result.json`.
    #[serde(skip)]
    pub descent: Option<Vec<Point>>,
}

/// Analyses `mesh` (a solution) with its bodies: each region with its prescribed pressure
/// (1/m), or `None` when its volume is held; reports the `reported` smallest eigenvalues (the
/// negative ones are counted whatever their number).
pub fn analyse(mesh: &Mesh, bodies: &[(&Region, Option<f64>)], reported: usize) -> Stability {
    analyse_with(mesh, bodies, reported, Method::ShiftInvert)
}

/// How the spectrum is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Method {
    /// [`shift_invert`], spectrum slicing when it cannot certify its result.
    ShiftInvert,
    /// The dense eigendecomposition (the tests' reference).
    #[cfg(test)]
    Dense,
    /// [`slicing`] only.
    #[cfg(test)]
    Slicing,
    /// [`shift_invert`] only: "not analysed" when it cannot certify its result.
    #[cfg(test)]
    ShiftInvertOnly,
}

/// [`analyse`] by `method`.
fn analyse_with(
    mesh: &Mesh,
    bodies: &[(&Region, Option<f64>)],
    reported: usize,
    method: Method,
) -> Stability {
    let dofs = normal_dofs(mesh);
    let k: usize = dofs.iter().map(|b| b.len()).sum();
    let mut result = Stability {
        degrees_of_freedom: k,
        smallest_eigenvalues: Vec::new(),
        eigenvalue_errors: Vec::new(),
        relative_precision: RELATIVE_PRECISION,
        negative: 0,
        verdict: String::new(),
        pressures: Vec::new(),
        descent: None,
    };
    if k == 0 || k > SPARSE_LIMIT {
        result.verdict =
            format!("not analysed: {k} normal degrees of freedom (limit {SPARSE_LIMIT})");
        return result;
    }
    // Column of each vertex's first degree of freedom, with the mass weights 1/√M folded in.
    let mut start = vec![0; dofs.len()];
    let mut next = 0;
    for (v, basis) in dofs.iter().enumerate() {
        start[v] = next;
        next += basis.len();
    }
    let weight: Vec<f64> = (0..mesh.vertex_count())
        .map(|v| match dofs[v].len() {
            0 => 0.0,
            _ => 1.0 / mixed_area(mesh, v).max(f64::MIN_POSITIVE).sqrt(),
        })
        .collect();
    let project = |grad: &[(usize, Point)]| -> DVector<f64> {
        let mut row = DVector::zeros(k);
        for &(v, g) in grad {
            for (d, e) in dofs[v].iter().enumerate() {
                row[start[v] + d] += weight[v] * e.dot(&g);
            }
        }
        row
    };
    // Pressures: the prescribed ones, and for the held volumes the least squares of
    // ∇A − Σ_prescribed p_j ∇V_j ≈ Σ p_i ∇V_i over the degrees of freedom.
    let area_grad: Vec<(usize, Point)> =
        total_area_gradient(mesh).into_iter().enumerate().collect();
    let mut free_energy_grad = project(&area_grad);
    let mut volume_rows: Vec<DVector<f64>> = Vec::new();
    for (region, pressure) in bodies {
        let row = project(&region.volume_gradient(mesh));
        match pressure {
            Some(p) => free_energy_grad -= row * *p,
            None => volume_rows.push(row),
        }
    }
    let mut fitted = least_squares(&volume_rows, &free_energy_grad).into_iter();
    let pressures: Vec<f64> = bodies
        .iter()
        .map(|(_, pressure)| pressure.or_else(|| fitted.next()).unwrap_or(0.0))
        .collect();
    // K = Bᵀ (∇²A − Σ p_i ∇²V_i) B, mass-weighted, as (row, column, value) entries (both
    // triangles; repeated positions add up).
    let mut entries: Vec<(usize, usize, f64)> = Vec::new();
    let mut add_blocks = |tri: [usize; 3], h: &[[Matrix3<f64>; 3]; 3], factor: f64| {
        for (a, row) in tri.iter().zip(h) {
            for (b, block) in tri.iter().zip(row) {
                for (i, ei) in dofs[*a].iter().enumerate() {
                    for (j, ej) in dofs[*b].iter().enumerate() {
                        entries.push((
                            start[*a] + i,
                            start[*b] + j,
                            factor * weight[*a] * weight[*b] * ei.dot(&(block * ej)),
                        ));
                    }
                }
            }
        }
    };
    for (t, &tri) in mesh.triangles().iter().enumerate() {
        add_blocks(tri, &triangle_area_hessian(&mesh.corners(t)), 1.0);
    }
    for ((region, _), p) in bodies.iter().zip(&pressures) {
        for &(s, sign) in &region.boundary {
            for t in mesh.surface_triangles(s) {
                let h = cone_volume_hessian(&mesh.corners(t), &region.reference);
                add_blocks(mesh.triangles()[t], &h, -p * sign);
            }
        }
    }
    // Allowed motion: keeps the volumes; without fixed vertices, no rigid motion either.
    let mut rows = volume_rows;
    if !mesh.flags().iter().any(|f| f.fixed || f.guide.is_some()) {
        let centre: Point =
            mesh.positions().iter().sum::<Point>() / mesh.vertex_count().max(1) as f64;
        for axis in [Point::x(), Point::y(), Point::z()] {
            let translation: Vec<(usize, Point)> =
                (0..mesh.vertex_count()).map(|v| (v, axis)).collect();
            let rotation: Vec<(usize, Point)> = mesh
                .positions()
                .iter()
                .enumerate()
                .map(|(v, x)| (v, axis.cross(&(x - centre))))
                .collect();
            // Modes in the weighted coordinates are M^{1/2} Bᵀ u: undo the 1/√M twice.
            for mode in [translation, rotation] {
                let mut row = project(&mode);
                for (v, basis) in dofs.iter().enumerate() {
                    for d in 0..basis.len() {
                        row[start[v] + d] /= weight[v] * weight[v];
                    }
                }
                rows.push(row);
            }
        }
    }
    let basis = independent_rows(&rows);

    let spectrum = match spectrum_by(k, &entries, &basis, reported, method) {
        Ok(spectrum) => spectrum,
        Err(e) => {
            result.verdict = format!("not analysed: {e}");
            return result;
        }
    };

    result.negative = spectrum.negative;
    if spectrum.negative > 0
        && let Some(&lowest) = spectrum.smallest.first()
        && let Ok(Some(w)) = lowest_mode(k, &entries, &basis, lowest)
    {
        // Back from the weighted coordinates (w = M^{1/2} u) to each vertex's motion.
        let motion = (0..mesh.vertex_count()).map(|v| {
            let amplitude = |(d, e): (usize, &Point)| e * (weight[v] * w[start[v] + d]);
            dofs[v].iter().enumerate().map(amplitude).sum()
        });
        result.descent = unit_motion(motion.collect());
    }
    result.smallest_eigenvalues = spectrum.smallest;
    result.eigenvalue_errors = spectrum.errors;
    result.verdict = verdict(
        result.negative,
        &result.smallest_eigenvalues,
        &result.eigenvalue_errors,
    );
    result.pressures = pressures;
    result
}

/// `motion` scaled to a largest vertex displacement of 1; `None` when it is all zero.
fn unit_motion(mut motion: Vec<Point>) -> Option<Vec<Point>> {
    let largest = motion.iter().map(|m| m.norm()).fold(0.0, f64::max);
    (largest > 0.0).then(|| {
        motion.iter_mut().for_each(|m| *m /= largest);
        motion
    })
}

/// Inverse-iteration steps of [`lowest_mode`].
const MODE_STEPS: usize = 30;

/// The eigenvector of K (k×k, `entries` of both triangles) on the complement of the orthonormal
/// `basis` for its smallest eigenvalue `lowest` (as computed): inverse iteration with the
/// bordered matrix factored at a shift a tenth of |lowest| below it, from a deterministic
/// spread start; `None` when the shift does not factor.
fn lowest_mode(
    k: usize,
    entries: &[(usize, usize, f64)],
    basis: &[DVector<f64>],
    lowest: f64,
) -> Result<Option<DVector<f64>>, crate::solver::kkt::KktError> {
    let mut bordered = bordered::Bordered::new(k, entries, basis)?;
    let shift = lowest - 0.1 * lowest.abs().max(f64::MIN_POSITIVE);
    if bordered.count(shift)? != 0 {
        return Ok(None);
    }
    let mut x: Vec<f64> = (0..k)
        .map(|i| ((i + 1) as f64 * 0.618_033_988_749_895).fract() - 0.5)
        .collect();
    for _ in 0..MODE_STEPS {
        bordered.solve(&mut x);
        let norm = x.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return Ok(None);
        }
        x.iter_mut().for_each(|v| *v /= norm);
    }
    Ok(Some(DVector::from_vec(x)))
}

/// The one-line verdict: a saddle when the certified count of negative eigenvalues is
/// positive; stable when none is negative and every reported eigenvalue is known to its
/// relative tolerance ([`tolerances`] without the 1e-10·g floor); otherwise not resolved. A mesh
/// with nearly collapsed triangles has a huge largest curvature scale g, and the eigenvalues'
/// bounds (never finer than 1e-10·g) and the negative threshold (−[`NEGATIVE_TOLERANCE`]·g)
/// then exceed the eigenvalues themselves: "stable" would claim what the count cannot see
/// (measured on an unconverged five-bubble cluster: six equal values 6.2e5 1/m², each ± 6.2e5).
fn verdict(negative: usize, eigenvalues: &[f64], errors: &[f64]) -> String {
    if negative > 0 {
        return format!(
            "saddle: {negative} negative eigenvalue(s), a descent direction the constraints allow"
        );
    }
    let tolerance = tolerances(eigenvalues, eigenvalues.len(), 0.0);
    match (eigenvalues.iter().zip(errors).zip(&tolerance)).find(|((_, e), t)| e > t) {
        Some(((value, error), _)) => format!(
            "not resolved: eigenvalue {value:.4e} ± {error:.3e} 1/m², above the stated \
             precision (a degenerate or unconverged mesh)"
        ),
        None => "stable".into(),
    }
}

/// The smallest eigenvalues of K (k×k, `entries` of both triangles) on the complement of the
/// orthonormal `basis`, by `method`.
fn spectrum_by(
    k: usize,
    entries: &[(usize, usize, f64)],
    basis: &[DVector<f64>],
    reported: usize,
    method: Method,
) -> Result<Spectrum, String> {
    let certified = match method {
        #[cfg(test)]
        Method::Dense => {
            let mut big_k = DMatrix::zeros(k, k);
            for &(i, j, v) in entries {
                big_k[(i, j)] += v;
            }
            return Ok(dense_spectrum(big_k, basis, reported));
        }
        #[cfg(test)]
        Method::Slicing => None,
        _ => {
            shift_invert::smallest(k, entries, basis, reported, NEGATIVE_TOLERANCE).unwrap_or(None)
        }
    };
    match certified {
        Some(spectrum) => Ok(spectrum),
        #[cfg(test)]
        None if method == Method::ShiftInvertOnly => Err("shift-invert not certified".into()),
        None => slicing::smallest(k, entries, basis, reported, NEGATIVE_TOLERANCE),
    }
}

/// Orthonormal bases of each vertex's normal motion (module header).
fn normal_dofs(mesh: &Mesh) -> Vec<Vec<Point>> {
    let mut junction_neighbours = vec![Vec::new(); mesh.vertex_count()];
    for e in mesh.edges().iter().filter(|e| e.triangles.len() >= 3) {
        let [a, b] = e.vertices;
        junction_neighbours[a].push(b);
        junction_neighbours[b].push(a);
    }
    let pos = mesh.positions();
    (0..mesh.vertex_count())
        .map(|v| {
            let f = mesh.flags()[v];
            if f.fixed || f.guide.is_some() {
                return Vec::new();
            }
            if mesh.curvature_surface(v).is_some() {
                let n: Point = mesh
                    .vertex_triangles(v)
                    .iter()
                    .map(|&t| area_vector(&mesh.corners(t)))
                    .sum();
                return vec![n.normalize()];
            }
            if let [a, b] = junction_neighbours[v].as_slice() {
                let (u, w) = super::mesh::orthonormal_pair(&(pos[*b] - pos[*a]).normalize());
                return vec![u, w];
            }
            vec![Point::x(), Point::y(), Point::z()]
        })
        .collect()
}

/// Least-squares coefficients `p` of `target ≈ Σ p_i rows_i`.
fn least_squares(rows: &[DVector<f64>], target: &DVector<f64>) -> Vec<f64> {
    let r = rows.len();
    if r == 0 {
        return Vec::new();
    }
    let gram = DMatrix::from_fn(r, r, |i, j| rows[i].dot(&rows[j]));
    let rhs = DVector::from_fn(r, |i, _| rows[i].dot(target));
    gram.svd(true, true)
        .solve(&rhs, 1e-12)
        .map(|p| p.iter().copied().collect())
        .unwrap_or_else(|_| vec![0.0; r])
}

/// An orthonormal basis of the span of `rows` (Gram–Schmidt). Rows that vanish (a rotation
/// about a sphere's centre has no normal part) or repeat others restrict nothing.
fn independent_rows(rows: &[DVector<f64>]) -> Vec<DVector<f64>> {
    let scale = rows.iter().fold(0.0f64, |m, r| m.max(r.norm()));
    let mut basis: Vec<DVector<f64>> = Vec::new();
    for row in rows {
        let mut q = row.clone();
        for b in &basis {
            q -= b * b.dot(&q);
        }
        let norm = q.norm();
        if norm > 1e-8 * scale {
            basis.push(q / norm);
        }
    }
    basis
}

/// The smallest eigenvalues of a symmetric matrix on the orthogonal complement of a basis, and
/// how many of all its eigenvalues there are negative.
#[derive(Debug, Clone, PartialEq)]
struct Spectrum {
    /// The smallest eigenvalues asked for, ascending.
    smallest: Vec<f64>,
    /// A bound on the error of each ([`Stability::eigenvalue_errors`]).
    errors: Vec<f64>,
    /// Eigenvalues below −[`NEGATIVE_TOLERANCE`] × the Gershgorin bound (× the largest
    /// magnitude in the dense reference).
    negative: usize,
}

/// The eigenvalues of `k` on the orthogonal complement of the orthonormal `basis`: those of
/// `P K P + s (I − P)` with `P` the projector onto the complement and `s` above the spectrum,
/// the `s` ones (one per basis vector) dropped; the error bounds are the backward-error
/// estimate n·ε·‖·‖_F of the dense solver, not a residual bound.
#[cfg(test)]
fn dense_spectrum(k: DMatrix<f64>, basis: &[DVector<f64>], reported: usize) -> Spectrum {
    let n = k.nrows();
    let mut p = DMatrix::identity(n, n);
    for b in basis {
        p -= b * b.transpose();
    }
    let shift = 10.0 * k.iter().fold(1.0f64, |m, e| m.max(e.abs())) * n as f64;
    let restricted = &p * k * &p + (DMatrix::identity(n, n) - &p) * shift;
    let mut eigenvalues: Vec<f64> = restricted.symmetric_eigenvalues().iter().copied().collect();
    eigenvalues.sort_by(f64::total_cmp);
    eigenvalues.truncate(n - basis.len());
    let largest = eigenvalues.iter().fold(0.0f64, |m, e| m.max(e.abs()));
    let negative = eigenvalues
        .iter()
        .filter(|&&e| e < -NEGATIVE_TOLERANCE * largest)
        .count();
    eigenvalues.truncate(reported);
    let backward = n as f64 * f64::EPSILON * restricted.norm();
    Spectrum {
        errors: vec![backward; eigenvalues.len()],
        smallest: eigenvalues,
        negative,
    }
}

/// The error tolerated in each of the ascending values `theta`, of which the first `reported`
/// are reported: [`RELATIVE_PRECISION`] × max(|θ_i|, the largest reported |θ_j|), and not below
/// [`ABSOLUTE_PRECISION`] × `g` (the Gershgorin bound).
fn tolerances(theta: &[f64], reported: usize, g: f64) -> Vec<f64> {
    let scale = theta[..reported.min(theta.len())]
        .iter()
        .fold(0.0f64, |m, t| m.max(t.abs()));
    theta
        .iter()
        .map(|t| (RELATIVE_PRECISION * t.abs().max(scale)).max(ABSOLUTE_PRECISION * g))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::catenoid::catenoid;
    use crate::cmc::testing::{onto_catenoid, unit_catenoid_branches};

    /// The catenoid `r = a·cosh(y/a)` between unit rings 1 apart, meshed like the generator's
    /// cylinder at `levels` and moved radially onto it.
    fn catenoid_mesh(a: f64, levels: usize) -> Mesh {
        onto_catenoid(catenoid(1.0, 1.0, levels).unwrap().mesh, a)
    }

    #[test]
    fn the_stable_catenoid_is_stable_and_the_unstable_branch_a_saddle() {
        let (stable, unstable) = unit_catenoid_branches();
        assert!((unstable - 0.2350).abs() < 1e-3, "{unstable}");
        let s = analyse(&catenoid_mesh(stable, 3), &[], REPORTED);
        assert_eq!(s.negative, 0, "{s:?}");
        assert_eq!(s.verdict, "stable");
        // Measured at 36 segments per ring: 6.67 (stable), −7.28 then 2.12 (unstable).
        assert!(s.smallest_eigenvalues[0] > 1.0, "{s:?}");
        assert!(s.descent.is_none());
        let mesh = catenoid_mesh(unstable, 3);
        let u = analyse(&mesh, &[], REPORTED);
        assert_eq!(u.negative, 1, "{u:?}");
        // The negative mode as a vertex motion: largest displacement 1, the rings held.
        let motion = u.descent.as_ref().unwrap();
        let largest = motion.iter().map(|m| m.norm()).fold(0.0, f64::max);
        assert!((largest - 1.0).abs() < 1e-12);
        for (m, f) in motion.iter().zip(mesh.flags()) {
            assert!(!f.fixed || m.norm() == 0.0);
        }
        assert!(u.verdict.starts_with("saddle"), "{u:?}");
        assert!(u.smallest_eigenvalues[0] < -1.0, "{u:?}");
        assert!(u.smallest_eigenvalues[1] > 0.0, "{u:?}");
    }

    #[test]
    fn a_sphere_under_its_volume_is_stable_and_reports_its_pressure() {
        // Icosphere of radius 2 (outward normals): p = 2H = 1/m; the rigid translations are
        // excluded, so no zero eigenvalue is left.
        let mesh = crate::cmc::generators::icosphere(2.0, 2, "skin").unwrap();
        let region = Region {
            boundary: vec![(0, 1.0)],
            reference: Point::zeros(),
        };
        let s = analyse(&mesh, &[(&region, None)], REPORTED);
        assert_eq!(s.negative, 0, "{s:?}");
        // The Jacobi operator −Δ − 2/R² with l = 0 (volume) and l = 1 (translations)
        // excluded: smallest eigenvalue (6 − 2)/R² = 1 /m², five-fold (l = 2).
        assert!((s.pressures[0] - 1.0).abs() < 0.05, "{s:?}");
        for e in &s.smallest_eigenvalues[..5] {
            assert!((e - 1.0).abs() < 0.05, "{s:?}");
        }
        assert!(s.smallest_eigenvalues[5] > 2.0, "{s:?}");
        assert_eq!(s.degrees_of_freedom, mesh.vertex_count());
    }

    #[test]
    fn eigenvalues_not_known_to_the_stated_precision_are_not_called_stable() {
        let values = [2.0e4, 5.0e4, 7.0e4];
        assert_eq!(verdict(0, &values, &[1e-9, 0.05, 0.069]), "stable");
        // A bound of 1e-6 × 7e4 is the stated precision; just above it is not resolved.
        let v = verdict(0, &values, &[1e-9, 0.05, 0.0701]);
        assert!(v.starts_with("not resolved"), "{v}");
        let v = verdict(0, &[6.2e5; 6], &[6.2e5; 6]);
        assert!(v.starts_with("not resolved"), "{v}");
        // A certified negative count is a saddle whatever the bounds.
        let v = verdict(1, &[-3.0e6, 2.8e4], &[3.0e6, 1.0]);
        assert!(v.starts_with("saddle: 1 negative"), "{v}");
    }

    #[test]
    fn a_sphere_at_a_prescribed_pressure_is_a_saddle() {
        // Radius 2 at p = 2/R = 1/m with the volume free: the l = 0 mode (uniform swelling)
        // is allowed, at −2/R² = −0.5 /m² (a free bubble at fixed pressure is unstable).
        let mesh = crate::cmc::generators::icosphere(2.0, 2, "skin").unwrap();
        let region = Region {
            boundary: vec![(0, 1.0)],
            reference: Point::zeros(),
        };
        let s = analyse(&mesh, &[(&region, Some(1.0))], REPORTED);
        assert_eq!(s.pressures, vec![1.0]);
        assert_eq!(s.negative, 1, "{s:?}");
        assert!(s.verdict.starts_with("saddle"), "{s:?}");
        assert!((s.smallest_eigenvalues[0] + 0.5).abs() < 0.05, "{s:?}");
        assert!((s.smallest_eigenvalues[1] - 1.0).abs() < 0.05, "{s:?}");
    }

    #[test]
    fn spectrum_slicing_and_shift_invert_agree_with_the_dense_eigendecomposition() {
        // The catenoid's unstable branch (one negative eigenvalue, no restriction rows but the
        // rigid motions' normal parts), the sphere under its volume (a five-fold cluster) and
        // at a prescribed pressure (a negative eigenvalue: the shift steps down below it).
        let (_, unstable) = unit_catenoid_branches();
        let catenoid = catenoid_mesh(unstable, 3);
        let sphere = crate::cmc::generators::icosphere(2.0, 2, "skin").unwrap();
        let region = Region {
            boundary: vec![(0, 1.0)],
            reference: Point::zeros(),
        };
        let cases = [
            (&catenoid, vec![]),
            (&sphere, vec![(&region, None)]),
            (&sphere, vec![(&region, Some(1.0))]),
        ];
        for (mesh, regions) in cases {
            let dense = analyse_with(mesh, &regions, REPORTED, Method::Dense);
            assert_eq!(dense.smallest_eigenvalues.len(), REPORTED);
            let scale = dense
                .smallest_eigenvalues
                .iter()
                .fold(1.0f64, |m, e| m.max(e.abs()));
            for method in [Method::Slicing, Method::ShiftInvertOnly] {
                let found = analyse_with(mesh, &regions, REPORTED, method);
                assert_eq!(dense.negative, found.negative, "{dense:?} {found:?}");
                assert_eq!(dense.verdict, found.verdict, "{method:?}");
                assert_eq!(found.smallest_eigenvalues.len(), REPORTED);
                for ((d, s), e) in dense
                    .smallest_eigenvalues
                    .iter()
                    .zip(&found.smallest_eigenvalues)
                    .zip(&found.eigenvalue_errors)
                {
                    assert!((d - s).abs() <= 1e-6 * scale, "{dense:?} {found:?}");
                    // The stated bound holds against the reference (up to its own rounding)
                    // and is within the stated precision.
                    let rounding = dense.eigenvalue_errors[0];
                    assert!((d - s).abs() <= e + rounding, "{dense:?} {found:?}");
                    assert!(*e <= RELATIVE_PRECISION * scale, "{found:?}");
                }
            }
        }
    }
}
