//! Triangle area with its exact gradient and Hessian, surface areas, and the mixed Voronoi
//! vertex area of Meyer, Desbrun, Schröder and Barr (2002), "Discrete differential-geometry
//! operators for triangulated 2-manifolds", §3.3 and Fig. 4 (seed eq. 5.3).
//!
//! For a triangle `p0, p1, p2` (metres) let `N = ½ (p1 − p0) × (p2 − p0)` be its area vector,
//! `a = |N|` its area (m²) and `n̂ = N / a`. With `e_k = p_{k+2} − p_{k+1}` (indices mod 3, the
//! edge opposite corner k, oriented along the triangle):
//! ```text
//!   ∂N/∂p_k = ½ [e_k]×            ∇_{p_k} a = ½ n̂ × e_k
//!   ∂²a/∂p_k∂p_l = ½ ( −[e_k]× ∂n̂/∂p_l + [n̂]× ∂e_k/∂p_l ),   ∂n̂/∂p_l = (I − n̂n̂ᵀ) ½[e_l]× / a
//! ```
//! where `∂e_k/∂p_l` is `+I` for `l = k+2`, `−I` for `l = k+1`, 0 for `l = k`. Meyer's cotangent
//! identity `2 ∇_{p_0} a = cot θ₂ (p0 − p1) + cot θ₁ (p0 − p2)` makes the area gradient the
//! cotangent Laplacian, so curvature derivatives reuse the area Hessian.
//!
//! Mixed area of corner 0 (Meyer Fig. 4): if the triangle is not obtuse, the Voronoi area
//! `(|p0 − p1|² cot θ₂ + |p0 − p2|² cot θ₁)/8` (seed eq. 5.3); if the angle at corner 0 is
//! obtuse, `a/2`; if another angle is obtuse, `a/4`. The three corners' mixed areas sum to `a`;
//! the rule is continuous across right angles, its gradient is not.

use nalgebra::Matrix3;

use super::mesh::{Mesh, Point};

/// Skew matrix `[v]×` with `[v]× w = v × w`.
pub fn skew(v: &Point) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Area (m²) of a triangle.
pub fn triangle_area(p: &[Point; 3]) -> f64 {
    0.5 * (p[1] - p[0]).cross(&(p[2] - p[0])).norm()
}

/// Area vector `½ (p1 − p0) × (p2 − p0)` (m², along the triangle's normal).
pub fn area_vector(p: &[Point; 3]) -> Point {
    0.5 * (p[1] - p[0]).cross(&(p[2] - p[0]))
}

/// Edge opposite corner `k`, oriented along the triangle: `p_{k+2} − p_{k+1}`.
fn opposite_edge(p: &[Point; 3], k: usize) -> Point {
    p[(k + 2) % 3] - p[(k + 1) % 3]
}

/// Gradient of the triangle area w.r.t. each corner (m).
pub fn triangle_area_gradient(p: &[Point; 3]) -> [Point; 3] {
    let n = area_vector(p).normalize();
    [0, 1, 2].map(|k| 0.5 * n.cross(&opposite_edge(p, k)))
}

/// Gradient of the triangle area w.r.t. corner `k` alone (m): entry k of
/// [`triangle_area_gradient`].
pub fn triangle_area_corner_gradient(p: &[Point; 3], k: usize) -> Point {
    0.5 * area_vector(p).normalize().cross(&opposite_edge(p, k))
}

/// Hessian of the triangle area as 3×3 blocks: `h[k][l] = ∂²a / ∂p_k ∂p_l` (dimensionless).
pub fn triangle_area_hessian(p: &[Point; 3]) -> [[Matrix3<f64>; 3]; 3] {
    let big_n = area_vector(p);
    let a = big_n.norm();
    let n = big_n / a;
    let projector = Matrix3::identity() - n * n.transpose();
    let dn: [Matrix3<f64>; 3] =
        [0, 1, 2].map(|l| projector * skew(&opposite_edge(p, l)) * (0.5 / a));
    let skew_n = skew(&n);
    let mut h = [[Matrix3::zeros(); 3]; 3];
    for (k, row) in h.iter_mut().enumerate() {
        let skew_e = skew(&opposite_edge(p, k));
        for (l, (entry, dn_l)) in row.iter_mut().zip(&dn).enumerate() {
            let mut block = -skew_e * dn_l;
            if l == (k + 2) % 3 {
                block += skew_n;
            } else if l == (k + 1) % 3 {
                block -= skew_n;
            }
            *entry = 0.5 * block;
        }
    }
    h
}

/// The triangle area's Hessian as a bilinear form, for contracting its blocks with a few
/// directions instead of forming all nine 3×3 blocks. With `x` a displacement of corner k
/// and `y` one of corner l (m), `xᵀ (∂²a/∂p_k∂p_l) y = (x × e_k)·(I − n̂n̂ᵀ)(y × e_l) / 4a
/// + s n̂·(x × y) / 2`, `s = +1` for `l = k+1`, `−1` for `l = k+2`, 0 for `l = k` (the module
/// header's blocks written out; dimensionless, like [`triangle_area_hessian`]).
#[derive(Debug, Clone, Copy)]
pub struct TriangleAreaForm {
    /// Unit normal n̂.
    normal: Point,
    /// Edges `e_k` opposite each corner (m).
    edges: [Point; 3],
    /// `1 / 4a` (1/m²).
    quarter_inverse_area: f64,
}

impl TriangleAreaForm {
    /// The form of the triangle with corners `p` (m); the triangle must not be degenerate.
    pub fn new(p: &[Point; 3]) -> Self {
        let big_n = area_vector(p);
        let a = big_n.norm();
        Self {
            normal: big_n / a,
            edges: [0, 1, 2].map(|k| opposite_edge(p, k)),
            quarter_inverse_area: 0.25 / a,
        }
    }

    /// `(∂²a/∂p_k∂p_l)ᵀ x`: the vector g with `g·y = xᵀ (∂²a/∂p_k∂p_l) y` (m, x in m).
    #[inline]
    pub fn row(&self, k: usize, l: usize, x: &Point) -> Point {
        let c = x.cross(&self.edges[k]);
        let projected = c - self.normal * self.normal.dot(&c);
        let g = self.edges[l].cross(&projected) * self.quarter_inverse_area;
        if l == (k + 1) % 3 {
            g + 0.5 * self.normal.cross(x)
        } else if l == (k + 2) % 3 {
            g - 0.5 * self.normal.cross(x)
        } else {
            g
        }
    }
}

/// The diagonal block `∂²a/∂p_k²` of [`triangle_area_hessian`] alone (dimensionless):
/// `−½ [e_k]× (I − n̂n̂ᵀ) ½[e_k]× / a`, positive semidefinite (the area is convex in one corner).
pub fn triangle_area_hessian_diagonal(p: &[Point; 3], k: usize) -> Matrix3<f64> {
    triangle_area_corner_derivatives(p, &area_vector(p), k).1
}

/// The gradient (m, [`triangle_area_corner_gradient`]) and diagonal Hessian block
/// (dimensionless, [`triangle_area_hessian_diagonal`]) of the triangle area w.r.t. corner `k`,
/// from the triangle's area vector `vector` ([`area_vector`] of `p`): one normalization for
/// both.
pub fn triangle_area_corner_derivatives(
    p: &[Point; 3],
    vector: &Point,
    k: usize,
) -> (Point, Matrix3<f64>) {
    let a = vector.norm();
    let n = vector / a;
    let e = opposite_edge(p, k);
    let projector = Matrix3::identity() - n * n.transpose();
    let skew_e = skew(&e);
    (0.5 * n.cross(&e), -0.25 / a * skew_e * projector * skew_e)
}

/// The mixed (Voronoi / obtuse-rule) area of corner 0 of a triangle, m², and its gradient
/// w.r.t. the three corners (m).
pub fn mixed_area_corner0(p: &[Point; 3]) -> (f64, [Point; 3]) {
    let a = triangle_area(p);
    let grad_a = triangle_area_gradient(p);
    // d_m = (p_{m+1} − p_m)·(p_{m+2} − p_m) = |..||..| cos θ_m.
    let d = |m: usize| (p[(m + 1) % 3] - p[m]).dot(&(p[(m + 2) % 3] - p[m]));
    if d(0) < 0.0 {
        return (0.5 * a, grad_a.map(|g| 0.5 * g));
    }
    if d(1) < 0.0 || d(2) < 0.0 {
        return (0.25 * a, grad_a.map(|g| 0.25 * g));
    }
    let (p0, p1, p2) = (p[0], p[1], p[2]);
    let u = p0 - p1;
    let w = p0 - p2;
    let (uu, ww) = (u.norm_squared(), w.norm_squared());
    let d1 = d(1);
    let d2 = d(2);
    // Gradients of d1 = (p2 − p1)·(p0 − p1) and d2 = (p0 − p2)·(p1 − p2).
    let grad_d1 = [p2 - p1, 2.0 * p1 - p0 - p2, p0 - p1];
    let grad_d2 = [p1 - p2, p0 - p2, 2.0 * p2 - p0 - p1];
    let grad_uu = [2.0 * u, -2.0 * u, Point::zeros()];
    let grad_ww = [2.0 * w, Point::zeros(), -2.0 * w];
    let num = uu * d2 + ww * d1;
    let area = num / (16.0 * a);
    let grad = [0, 1, 2].map(|k| {
        let grad_num = d2 * grad_uu[k] + uu * grad_d2[k] + d1 * grad_ww[k] + ww * grad_d1[k];
        grad_num / (16.0 * a) - area * grad_a[k] / a
    });
    (area, grad)
}

/// Triangle `t`'s corners rotated so that vertex `v` comes first, with their vertex indices.
pub fn corners_from(mesh: &Mesh, t: usize, v: usize) -> ([usize; 3], [Point; 3]) {
    let tri = mesh.triangles()[t];
    let k = tri.iter().position(|&w| w == v).unwrap_or(0);
    let ids = [tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]];
    (ids, ids.map(|i| mesh.positions()[i]))
}

/// Mixed area of vertex `v` over the triangles of its star, m² (Meyer's A_mixed).
pub fn mixed_area(mesh: &Mesh, v: usize) -> f64 {
    mesh.vertex_triangles(v)
        .iter()
        .map(|&t| mixed_area_corner0(&corners_from(mesh, t, v).1).0)
        .sum()
}

/// Area of every surface, m².
pub fn surface_areas(mesh: &Mesh) -> Vec<f64> {
    let mut areas = vec![0.0; mesh.surfaces().len()];
    for t in 0..mesh.triangles().len() {
        areas[mesh.triangle_surface()[t]] += triangle_area(&mesh.corners(t));
    }
    areas
}

/// Total area of all surfaces, m².
pub fn total_area(mesh: &Mesh) -> f64 {
    surface_areas(mesh).iter().sum()
}

/// Gradient of the total area w.r.t. every vertex position (m).
pub fn total_area_gradient(mesh: &Mesh) -> Vec<Point> {
    let mut g = vec![Point::zeros(); mesh.vertex_count()];
    for (t, tri) in mesh.triangles().iter().enumerate() {
        let gt = triangle_area_gradient(&mesh.corners(t));
        for k in 0..3 {
            g[tri[k]] += gt[k];
        }
    }
    g
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::testing::{central_difference, random_triangle};

    #[test]
    fn area_gradient_matches_central_differences() {
        let mut rng = crate::cmc::testing::rng(1);
        for _ in 0..50 {
            let p = random_triangle(&mut rng);
            let g = triangle_area_gradient(&p);
            for (k, gk) in g.iter().enumerate() {
                let fd = central_difference(&p, k, 1e-6, triangle_area);
                assert!((gk - fd).norm() < 1e-8, "{gk} vs {fd}");
            }
        }
    }

    #[test]
    fn area_hessian_matches_central_differences_and_is_symmetric() {
        let mut rng = crate::cmc::testing::rng(2);
        for _ in 0..50 {
            let p = random_triangle(&mut rng);
            let h = triangle_area_hessian(&p);
            for (k, row) in h.iter().enumerate() {
                assert!((triangle_area_hessian_diagonal(&p, k) - row[k]).norm() < 1e-12);
                for (l, block) in row.iter().enumerate() {
                    assert!((block - h[l][k].transpose()).norm() < 1e-12);
                    for c in 0..3 {
                        // Column c of block (k, l): derivative of ∇_{p_k} a along p_l's c axis.
                        let mut plus = p;
                        let mut minus = p;
                        plus[l][c] += 1e-6;
                        minus[l][c] -= 1e-6;
                        let fd = (triangle_area_gradient(&plus)[k]
                            - triangle_area_gradient(&minus)[k])
                            / 2e-6;
                        let exact = block.column(c).into_owned();
                        assert!((exact - fd).norm() < 1e-6, "{exact} vs {fd}");
                    }
                }
            }
        }
    }

    #[test]
    fn area_form_rows_are_the_hessian_blocks_transposed_times_x() {
        let mut rng = crate::cmc::testing::rng(7);
        for _ in 0..50 {
            let p = random_triangle(&mut rng);
            let x = random_triangle(&mut rng)[0];
            let h = triangle_area_hessian(&p);
            let form = TriangleAreaForm::new(&p);
            for (k, row) in h.iter().enumerate() {
                for (l, block) in row.iter().enumerate() {
                    let expected = block.transpose() * x;
                    let got = form.row(k, l, &x);
                    assert!((got - expected).norm() < 1e-12 * (1.0 + expected.norm()));
                }
            }
        }
    }

    #[test]
    fn vertex_mixed_areas_sum_to_the_total_area() {
        let mut rng = crate::cmc::testing::rng(6);
        let sphere = crate::cmc::generators::icosphere(1.0, 2, "s").unwrap();
        let mesh = crate::cmc::testing::perturbed(&sphere, 0.3, &mut rng);
        let obtuse = (0..mesh.vertex_count())
            .filter(|&v| crate::cmc::testing::has_obtuse(&mesh, v))
            .count();
        assert!(obtuse > 10, "{obtuse}");
        let sum: f64 = (0..mesh.vertex_count()).map(|v| mixed_area(&mesh, v)).sum();
        assert!((sum - total_area(&mesh)).abs() < 1e-12 * total_area(&mesh));
    }

    #[test]
    fn cotangent_identity_holds() {
        let mut rng = crate::cmc::testing::rng(3);
        let p = random_triangle(&mut rng);
        let cot = |m: usize| {
            let a = p[(m + 1) % 3] - p[m];
            let b = p[(m + 2) % 3] - p[m];
            a.dot(&b) / a.cross(&b).norm()
        };
        let g = triangle_area_gradient(&p)[0];
        let cot_form = 0.5 * (cot(2) * (p[0] - p[1]) + cot(1) * (p[0] - p[2]));
        assert!((g - cot_form).norm() < 1e-12);
    }

    #[test]
    fn mixed_areas_partition_the_triangle() {
        let mut rng = crate::cmc::testing::rng(4);
        let mut obtuse = 0;
        for _ in 0..200 {
            let p = random_triangle(&mut rng);
            let a = triangle_area(&p);
            let sum: f64 = (0..3)
                .map(|k| mixed_area_corner0(&[p[k], p[(k + 1) % 3], p[(k + 2) % 3]]).0)
                .sum();
            assert!((sum - a).abs() < 1e-12 * a.max(1.0), "{sum} vs {a}");
            let d0 = (p[1] - p[0]).dot(&(p[2] - p[0]));
            let d1 = (p[2] - p[1]).dot(&(p[0] - p[1]));
            let d2 = (p[0] - p[2]).dot(&(p[1] - p[2]));
            obtuse += usize::from(d0 < 0.0 || d1 < 0.0 || d2 < 0.0);
        }
        assert!(obtuse > 20, "the sample must contain obtuse triangles");
    }

    #[test]
    fn mixed_area_gradient_matches_central_differences() {
        let mut rng = crate::cmc::testing::rng(5);
        let mut cases = [0usize; 3];
        for _ in 0..300 {
            let p = random_triangle(&mut rng);
            let (_, g) = mixed_area_corner0(&p);
            // Skip triangles within the finite-difference step of a right angle (kink).
            let cos = |m: usize| {
                let a = p[(m + 1) % 3] - p[m];
                let b = p[(m + 2) % 3] - p[m];
                a.dot(&b) / (a.norm() * b.norm())
            };
            if (0..3).any(|m| cos(m).abs() < 1e-3) {
                continue;
            }
            let case = if cos(0) < 0.0 {
                0
            } else if cos(1) < 0.0 || cos(2) < 0.0 {
                1
            } else {
                2
            };
            cases[case] += 1;
            for (k, gk) in g.iter().enumerate() {
                let fd = central_difference(&p, k, 1e-6, |q| mixed_area_corner0(q).0);
                assert!((gk - fd).norm() < 1e-7, "case {case}: {gk} vs {fd}");
            }
        }
        assert!(cases.iter().all(|&c| c > 10), "cases covered: {cases:?}");
    }
}
