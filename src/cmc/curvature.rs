//! Discrete mean curvature at a vertex (Meyer, Desbrun, Schröder, Barr 2002; seed eq. 5.2–5.3)
//! and its exact gradient w.r.t. the vertex and its 1-ring.
//!
//! At a vertex `i` whose star is a closed disk in one surface:
//! ```text
//!   L   = Σ_j (cot α_ij + cot β_ij)(x_i − x_j) = 2 Σ_{t∋i} ∇_{x_i} area(t)     (m)
//!   A   = Σ_{t∋i} A_mixed(t, i)                                                 (m²)
//!   N   = Σ_{t∋i} ½ (p1 − p0) × (p2 − p0),   n̂ = N / |N|                         (vertex normal)
//!   H_i = (L · n̂) / (4 A)                                                        (1/m)
//! ```
//! `L / (2A)` is Meyer's mean-curvature normal `K = 2 H n`; seed eq. 5.2 prints its norm, which
//! loses the sign and is not differentiable on minimal surfaces (H = 0), so we project on the
//! area-weighted normal instead. Sign convention: the normal follows the triangles' orientation
//! and `H > 0` when the surface bends away from its normal, e.g. `H = 1/R` on a sphere of radius
//! R with outward-facing triangles; a flat vertex has `H = 0`.
//!
//! Gradient (per ring triangle t with corners `p0 = x_i, p1, p2`, blocks of the area Hessian
//! `∂²a/∂p_0∂p_m`, see [`super::area`]):
//! ```text
//!   ∂H/∂p_m = [ 2 (∂²a/∂p_0∂p_m)ᵀ n̂ + ½ [e_m]×ᵀ (I − n̂n̂ᵀ) L / |N| ] / (4A) − H (∂A_t/∂p_m) / A
//! ```
//! Junction vertices (on edges shared by three or more films), boundary, fixed, guided and
//! excluded vertices carry no curvature constraint (seed §5.3): their position is set by the
//! area minimization alone, which balances the films' conormals and yields the 120° Plateau
//! angles. Attributing the junction vertex's non-manifold star to one film's mixed area would
//! bias that balance (junctions settle near 135°); [`junction_curvature`] reports, for
//! diagnostics only, the average over the films meeting there of the H of their adjacent
//! curvature vertices.

use std::collections::BTreeMap;

use super::area::{
    corners_from, mixed_area_corner0, triangle_area_gradient, triangle_area_hessian,
};
use super::mesh::{Mesh, Point};

/// Why the curvature at a vertex is undefined.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CurvatureError {
    /// The vertex normal or the mixed area vanished (a folded or collapsed star).
    #[error("curvature undefined at vertex {0}: its star is folded or collapsed")]
    Degenerate(usize),
}

/// Mean curvature H (1/m) at vertex `i`, see the module header.
pub fn mean_curvature(mesh: &Mesh, i: usize) -> Result<f64, CurvatureError> {
    Ok(parts(mesh, i)?.h)
}

/// The accumulated pieces of H at a vertex.
struct Parts {
    l: Point,
    normal: Point,
    area: f64,
    h: f64,
}

fn parts(mesh: &Mesh, i: usize) -> Result<Parts, CurvatureError> {
    let mut l = Point::zeros();
    let mut normal = Point::zeros();
    let mut area = 0.0;
    for &t in mesh.vertex_triangles(i) {
        let (_, p) = corners_from(mesh, t, i);
        l += 2.0 * triangle_area_gradient(&p)[0];
        normal += 0.5 * (p[1] - p[0]).cross(&(p[2] - p[0]));
        area += mixed_area_corner0(&p).0;
    }
    let len = normal.norm();
    if !(len > 0.0 && area > 0.0 && l.iter().all(|c| c.is_finite())) {
        return Err(CurvatureError::Degenerate(i));
    }
    let h = l.dot(&(normal / len)) / (4.0 * area);
    Ok(Parts { l, normal, area, h })
}

/// H at vertex `i` (1/m) and its gradient (1/m²) w.r.t. `i` and each 1-ring vertex, as
/// `(vertex, ∂H/∂x_vertex)` pairs: `i` first, then the neighbours in ascending order.
pub fn mean_curvature_gradient(
    mesh: &Mesh,
    i: usize,
) -> Result<(f64, Vec<(usize, Point)>), CurvatureError> {
    let Parts { l, normal, area, h } = parts(mesh, i)?;
    let len = normal.norm();
    let n = normal / len;
    // w = (I − n̂n̂ᵀ) L / |N|: how L·n̂ changes with N.
    let w = (l - n * n.dot(&l)) / len;
    let mut grad: BTreeMap<usize, Point> = BTreeMap::new();
    for &t in mesh.vertex_triangles(i) {
        let (ids, p) = corners_from(mesh, t, i);
        let hess = triangle_area_hessian(&p);
        let (_, grad_mixed) = mixed_area_corner0(&p);
        for m in 0..3 {
            let e = p[(m + 2) % 3] - p[(m + 1) % 3];
            let from_l = 2.0 * hess[0][m].transpose() * n;
            // [e]×ᵀ w = w × e.
            let from_n = 0.5 * w.cross(&e);
            let g = (from_l + from_n) / (4.0 * area) - h * grad_mixed[m] / area;
            *grad.entry(ids[m]).or_insert_with(Point::zeros) += g;
        }
    }
    let centre = grad.remove(&i).unwrap_or_else(Point::zeros);
    let mut out = Vec::with_capacity(grad.len() + 1);
    out.push((i, centre));
    out.extend(grad);
    Ok((h, out))
}

/// For each junction vertex, the mean over the surfaces meeting there of the average H of that
/// surface's curvature vertices adjacent to the junction vertex (1/m). Diagnostic only.
pub fn junction_curvature(mesh: &Mesh) -> Vec<(usize, f64)> {
    mesh.junction_vertices()
        .into_iter()
        .filter_map(|v| {
            let mut per_surface: BTreeMap<usize, (f64, usize)> = BTreeMap::new();
            for &w in mesh.neighbours(v) {
                if let (Some(s), Ok(h)) = (mesh.curvature_surface(w), mean_curvature(mesh, w)) {
                    let e = per_surface.entry(s).or_insert((0.0, 0));
                    e.0 += h;
                    e.1 += 1;
                }
            }
            if per_surface.is_empty() {
                return None;
            }
            let sum: f64 = per_surface.values().map(|(h, c)| h / *c as f64).sum();
            Some((v, sum / per_surface.len() as f64))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators::icosphere;
    use crate::cmc::testing::{perturbed, rng};

    #[test]
    fn sphere_curvature_is_one_over_r_with_outward_normals() {
        let radius = 0.3;
        let mut previous = f64::INFINITY;
        for level in [2, 3, 4] {
            let mesh = icosphere(radius, level, "skin").unwrap();
            let worst = (0..mesh.vertex_count())
                .map(|v| (mean_curvature(&mesh, v).unwrap() * radius - 1.0).abs())
                .fold(0.0, f64::max);
            assert!(worst < previous, "level {level}: {worst} ≥ {previous}");
            previous = worst;
        }
        assert!(previous < 2e-3, "relative H error {previous}");
    }

    #[test]
    fn flat_vertex_has_zero_curvature() {
        let mesh = icosphere(1.0, 1, "skin").unwrap();
        // Flatten a copy: project the 1-ring of vertex 0 onto its tangent plane.
        let p0 = mesh.positions()[0];
        let n = p0.normalize();
        let mut pos = mesh.positions().to_vec();
        for &w in mesh.neighbours(0) {
            let d = pos[w] - p0;
            pos[w] = p0 + d - n * n.dot(&d);
        }
        let mut flat = mesh.clone();
        flat.set_positions(pos).unwrap();
        assert!(mean_curvature(&flat, 0).unwrap().abs() < 1e-12);
    }

    #[test]
    fn curvature_gradient_matches_central_differences() {
        let mut rng = rng(11);
        let base = icosphere(1.0, 2, "skin").unwrap();
        let mut obtuse_stars = 0;
        for trial in 0..6 {
            let mesh = perturbed(&base, 0.3, &mut rng);
            for v in (trial..mesh.vertex_count()).step_by(7) {
                if crate::cmc::testing::near_right_angle(&mesh, v, 2e-3) {
                    continue;
                }
                obtuse_stars += usize::from(crate::cmc::testing::has_obtuse(&mesh, v));
                let (_, grad) = mean_curvature_gradient(&mesh, v).unwrap();
                for (w, g) in grad {
                    for c in 0..3 {
                        let h = 1e-6;
                        let eval = |delta: f64| {
                            let mut pos = mesh.positions().to_vec();
                            pos[w][c] += delta;
                            let mut m = mesh.clone();
                            m.set_positions(pos).unwrap();
                            mean_curvature(&m, v).unwrap()
                        };
                        let fd = (eval(h) - eval(-h)) / (2.0 * h);
                        assert!(
                            (g[c] - fd).abs() < 1e-6 * (1.0 + fd.abs()),
                            "vertex {v}, wrt {w}[{c}]: {} vs {fd}",
                            g[c]
                        );
                    }
                }
            }
        }
        assert!(obtuse_stars > 5, "obtuse stars tested: {obtuse_stars}");
    }
}
