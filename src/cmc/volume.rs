//! Enclosed volumes and chord lengths with exact gradients and Hessians.
//!
//! A region is a signed list of surfaces `(s, ±1)`: `+1` when the surface's triangles face out
//! of the region, `−1` when they face into it. By the divergence theorem its volume (m³) is
//! ```text
//!   V = Σ_{(s, σ)} σ Σ_{t ∈ s} ⅙ (p0 − o) · ((p1 − o) × (p2 − o))
//! ```
//! for any reference point `o` when the listed surfaces close the region. A region closed in
//! part by a fixed plane (a dome or cushion on the ground) is exact when `o` lies on that plane,
//! because the cones from `o` over the missing planar faces are flat; with two or more fixed
//! planes put `o` on their common line or point. Gradient and Hessian blocks per triangle:
//! ```text
//!   ∇_{p_k} V_t = ⅙ (p_{k+1} − o) × (p_{k+2} − o),   ∂²V_t/∂p_k∂p_{k+1} = −⅙ [p_{k+2} − o]×
//! ```
//! A chord is the distance `|x_a − x_b|` (m) between two vertices, gradient `±(x_a − x_b)/|…|`.

use nalgebra::Matrix3;

use super::area::skew;
use super::mesh::{Mesh, Point};

/// A region bounded by surfaces of a mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// `(surface index, +1.0 or −1.0)`: +1 when the surface's normals point out of the region.
    pub boundary: Vec<(usize, f64)>,
    /// Reference point of the cone decomposition (m); on the fixed plane for open regions.
    pub reference: Point,
}

/// Signed volume of the cone from `o` over a triangle, m³.
pub fn cone_volume(p: &[Point; 3], o: &Point) -> f64 {
    (p[0] - o).dot(&(p[1] - o).cross(&(p[2] - o))) / 6.0
}

/// Gradient of [`cone_volume`] w.r.t. each corner (m²).
pub fn cone_volume_gradient(p: &[Point; 3], o: &Point) -> [Point; 3] {
    [0, 1, 2].map(|k| cone_volume_corner_gradient(p, o, k))
}

/// Gradient of [`cone_volume`] w.r.t. corner `k` alone (m²).
pub fn cone_volume_corner_gradient(p: &[Point; 3], o: &Point, k: usize) -> Point {
    (p[(k + 1) % 3] - o).cross(&(p[(k + 2) % 3] - o)) / 6.0
}

/// Hessian blocks `h[k][l] = ∂²V/∂p_k∂p_l` of [`cone_volume`] (m).
pub fn cone_volume_hessian(p: &[Point; 3], o: &Point) -> [[Matrix3<f64>; 3]; 3] {
    let mut h = [[Matrix3::zeros(); 3]; 3];
    for (k, row) in h.iter_mut().enumerate() {
        let next = (k + 1) % 3;
        let other = (k + 2) % 3;
        // ∇_{p_k} V = ⅙ (p_next − o) × (p_other − o) = −⅙ [p_other − o]× (p_next − o).
        row[next] = -skew(&(p[other] - o)) / 6.0;
        row[other] = skew(&(p[next] - o)) / 6.0;
    }
    h
}

impl Region {
    /// Volume of the region, m³.
    pub fn volume(&self, mesh: &Mesh) -> f64 {
        self.boundary
            .iter()
            .map(|&(s, sign)| {
                sign * mesh
                    .surface_triangles(s)
                    .map(|t| cone_volume(&mesh.corners(t), &self.reference))
                    .sum::<f64>()
            })
            .sum()
    }

    /// Gradient of the volume, as `(vertex, ∂V/∂x_vertex)` pairs sorted by vertex (m²).
    pub fn volume_gradient(&self, mesh: &Mesh) -> Vec<(usize, Point)> {
        // Accumulated per vertex in triangle order, then listed by vertex.
        let mut grad: Vec<Option<Point>> = vec![None; mesh.vertex_count()];
        for &(s, sign) in &self.boundary {
            for t in mesh.surface_triangles(s) {
                let g = cone_volume_gradient(&mesh.corners(t), &self.reference);
                for (k, &v) in mesh.triangles()[t].iter().enumerate() {
                    *grad[v].get_or_insert_with(Point::zeros) += sign * g[k];
                }
            }
        }
        grad.into_iter()
            .enumerate()
            .filter_map(|(v, g)| Some((v, g?)))
            .collect()
    }

    /// Vertices whose positions the volume depends on, ascending.
    pub fn vertices(&self, mesh: &Mesh) -> Vec<usize> {
        self.volume_gradient(mesh)
            .into_iter()
            .map(|(v, _)| v)
            .collect()
    }
}

/// Distance between vertices `a` and `b` (m) and its gradient w.r.t. `x_a` (that w.r.t. `x_b`
/// is its negative).
pub fn chord(mesh: &Mesh, a: usize, b: usize) -> (f64, Point) {
    let d = mesh.positions()[a] - mesh.positions()[b];
    let len = d.norm();
    (len, d / len)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::generators::icosphere;
    use crate::cmc::testing::{central_difference, perturbed, random_triangle, rng};

    #[test]
    fn closed_polyhedron_volume_is_exact_and_origin_free() {
        // The unit cube, 12 outward triangles.
        let mut b = crate::cmc::mesh::MeshBuilder::new();
        let s = b.surface("cube");
        let v: Vec<usize> = (0..8)
            .map(|i| {
                b.vertex(Point::new(
                    f64::from(i & 1),
                    f64::from((i >> 1) & 1),
                    f64::from((i >> 2) & 1),
                ))
            })
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        for q in quads {
            b.triangle(s, [v[q[0]], v[q[1]], v[q[2]]]);
            b.triangle(s, [v[q[0]], v[q[2]], v[q[3]]]);
        }
        let mesh = b.build().unwrap();
        for o in [Point::zeros(), Point::new(3.0, -2.0, 0.5)] {
            let r = Region {
                boundary: vec![(0, 1.0)],
                reference: o,
            };
            assert!((r.volume(&mesh) - 1.0).abs() < 1e-14);
        }
    }

    #[test]
    fn icosphere_volume_converges_to_the_ball() {
        let mesh = icosphere(2.0, 5, "skin").unwrap();
        let r = Region {
            boundary: vec![(0, 1.0)],
            reference: Point::zeros(),
        };
        let exact = 4.0 / 3.0 * std::f64::consts::PI * 8.0;
        assert!(r.volume(&mesh) < exact);
        assert!((r.volume(&mesh) / exact - 1.0).abs() < 2e-3);
    }

    #[test]
    fn volume_gradient_and_hessian_match_central_differences() {
        let mut rng = rng(21);
        let o = Point::new(0.3, -0.2, 0.1);
        for _ in 0..20 {
            let p = random_triangle(&mut rng);
            let g = cone_volume_gradient(&p, &o);
            let h = cone_volume_hessian(&p, &o);
            for k in 0..3 {
                let fd = central_difference(&p, k, 1e-6, |q| cone_volume(q, &o));
                assert!((g[k] - fd).norm() < 1e-9);
                for l in 0..3 {
                    assert!((h[k][l] - h[l][k].transpose()).norm() < 1e-14);
                    for c in 0..3 {
                        let mut plus = p;
                        let mut minus = p;
                        plus[l][c] += 1e-6;
                        minus[l][c] -= 1e-6;
                        let fd = (cone_volume_gradient(&plus, &o)[k]
                            - cone_volume_gradient(&minus, &o)[k])
                            / 2e-6;
                        assert!((h[k][l].column(c) - fd).norm() < 1e-8);
                    }
                }
            }
        }
        // The assembled region gradient on a perturbed sphere.
        let mesh = perturbed(&icosphere(1.0, 1, "skin").unwrap(), 0.1, &mut rng);
        let r = Region {
            boundary: vec![(0, -1.0)],
            reference: o,
        };
        for (v, g) in r.volume_gradient(&mesh) {
            for c in 0..3 {
                let eval = |d: f64| {
                    let mut pos = mesh.positions().to_vec();
                    pos[v][c] += d;
                    let mut m = mesh.clone();
                    m.set_positions(pos).unwrap();
                    r.volume(&m)
                };
                let fd = (eval(1e-6) - eval(-1e-6)) / 2e-6;
                assert!((g[c] - fd).abs() < 1e-8);
            }
        }
    }

    #[test]
    fn chord_gradient_matches_central_differences() {
        let mut rng = rng(22);
        let mesh = perturbed(&icosphere(1.0, 1, "skin").unwrap(), 0.1, &mut rng);
        let (len, g) = chord(&mesh, 0, 5);
        assert!((len - (mesh.positions()[0] - mesh.positions()[5]).norm()).abs() < 1e-15);
        for c in 0..3 {
            let eval = |d: f64| {
                let mut pos = mesh.positions().to_vec();
                pos[0][c] += d;
                let mut m = mesh.clone();
                m.set_positions(pos).unwrap();
                chord(&m, 0, 5).0
            };
            assert!((g[c] - (eval(1e-6) - eval(-1e-6)) / 2e-6).abs() < 1e-9);
        }
    }
}
