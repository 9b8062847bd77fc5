//! Exact Hessian of the discrete mean curvature `H_i` (seed eq. 5.2–5.3, [`super::curvature`])
//! w.r.t. the vertex and its 1-ring, by the chain rule through seven star sums.
//!
//! `H_i = g(q)` with `q = (L, N, A)` (7 numbers) and `g(L, N, A) = L·N / (4 A |N|)`, where each
//! of `L = Σ_t 2∇_{p0} a_t`, `N = Σ_t ½ (p1 − p0) × (p2 − p0)` and `A = Σ_t A_mixed(t, i)` is a
//! sum over the star triangles `t` (corners `p0 = x_i, p1, p2`, metres) of a function of that
//! triangle's edge vectors `e = (p1 − p0, p2 − p0)` alone (all three are invariant under
//! translation). Hence
//! ```text
//!   ∇²H = Jᵀ (∇²g) J + Σ_t P_tᵀ Eᵀ (Σ_k ∂g/∂q_k ∇²_e q_{k,t}) E P_t          (1/m³)
//! ```
//! with `J = ∂q/∂x`, `E = [−I I 0; −I 0 I]` the 6×9 map from a triangle's corners to its edge
//! vectors and `P_t` scattering a triangle's nine coordinates into the star's. The
//! per-triangle values, gradients and 6×6 Hessians of `q_{k,t}` and the 7×7 Hessian of `g` are
//! computed exactly (to rounding) with second-order forward-mode numbers (`hyperdual`): no
//! finite differences. The mixed area is piecewise smooth (Meyer's obtuse rules switch at
//! right angles); its Hessian is that of the active piece, consistent with
//! [`super::area::mixed_area_corner0`]'s gradient.

mod hyperdual;

use nalgebra::DMatrix;

use super::area::corners_from;
use super::curvature::CurvatureError;
use super::mesh::Mesh;
use hyperdual::Hyper;

type V3<const N: usize> = [Hyper<N>; 3];

fn sub<const N: usize>(a: &V3<N>, b: &V3<N>) -> V3<N> {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross<const N: usize>(a: &V3<N>, b: &V3<N>) -> V3<N> {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot<const N: usize>(a: &V3<N>, b: &V3<N>) -> Hyper<N> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// The seven per-triangle pieces `(2∇_{p0} a, ½ (p1 − p0) × (p2 − p0), A_mixed(corner 0))` of a
/// triangle with corners `p0, p1 = p0 + e1, p2 = p0 + e2`, given its edge vectors
/// `e = (e1, e2)` as six seed variables.
fn triangle_pieces(e: &[Hyper<6>; 6]) -> [Hyper<6>; 7] {
    let e1 = [e[0], e[1], e[2]];
    let e2 = [e[3], e[4], e[5]];
    let big_n = cross(&e1, &e2).map(|c| c * 0.5);
    let a = dot(&big_n, &big_n).sqrt();
    let n = big_n.map(|c| c / a);
    // 2∇_{p0} a = n̂ × e_0, e_0 = p2 − p1 (see super::area).
    let e0 = sub(&e2, &e1);
    let l = cross(&n, &e0);
    // d_m = (p_{m+1} − p_m)·(p_{m+2} − p_m): d_0 = e1·e2, d_1 = e0·(−e1), d_2 = (−e2)·(−e0).
    let d0 = dot(&e1, &e2).re;
    let d1 = || Hyper::constant(0.0) - dot(&e0, &e1);
    let d2 = || dot(&e2, &e0);
    let mixed = if d0 < 0.0 {
        a * 0.5
    } else if d1().re < 0.0 || d2().re < 0.0 {
        a * 0.25
    } else {
        (dot(&e1, &e1) * d2() + dot(&e2, &e2) * d1()) / (a * 16.0)
    };
    let [l0, l1, l2] = l;
    let [n0, n1, n2] = big_n;
    [l0, l1, l2, n0, n1, n2, mixed]
}

/// `g(L, N, A) = L·N / (4 A |N|)`.
fn star_curvature(q: &[Hyper<7>; 7]) -> Hyper<7> {
    let l = [q[0], q[1], q[2]];
    let n = [q[3], q[4], q[5]];
    dot(&l, &n) / (q[6] * 4.0 * dot(&n, &n).sqrt())
}

/// The exact Hessian of `H_i` (1/m³): the vertices it depends on (`i` first, then its
/// neighbours in ascending order, as in [`super::curvature::mean_curvature_gradient`]) and the
/// dense symmetric matrix over their coordinates (3 per vertex, in that order).
pub fn mean_curvature_hessian(
    mesh: &Mesh,
    i: usize,
) -> Result<(Vec<usize>, DMatrix<f64>), CurvatureError> {
    let mut vertices = vec![i];
    let mut ring = mesh.neighbours(i).to_vec();
    ring.sort_unstable();
    vertices.extend(ring);
    let local = |v: usize| vertices.iter().position(|&w| w == v);
    let dim = 3 * vertices.len();
    let mut q = [0.0; 7];
    // J = ∂q/∂x, 7 × dim column-major.
    let mut jac = DMatrix::<f64>::zeros(7, dim);
    let mut pieces = Vec::with_capacity(mesh.vertex_triangles(i).len());
    for &t in mesh.vertex_triangles(i) {
        let (ids, p) = corners_from(mesh, t, i);
        let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
        let seeds: [Hyper<6>; 6] =
            std::array::from_fn(|k| Hyper::variable(if k < 3 { e1[k] } else { e2[k - 3] }, k));
        let parts = triangle_pieces(&seeds);
        let mut slots = [0; 3];
        for (slot, &v) in slots.iter_mut().zip(&ids) {
            *slot = 3 * local(v).ok_or(CurvatureError::Degenerate(i))?;
        }
        for (k, part) in parts.iter().enumerate() {
            q[k] += part.re;
            for c in 0..3 {
                let (g1, g2) = (part.grad[c], part.grad[3 + c]);
                jac[(k, slots[0] + c)] -= g1 + g2;
                jac[(k, slots[1] + c)] += g1;
                jac[(k, slots[2] + c)] += g2;
            }
        }
        pieces.push((slots, parts));
    }
    let norm = (q[3] * q[3] + q[4] * q[4] + q[5] * q[5]).sqrt();
    if !(norm > 0.0 && q[6] > 0.0 && q.iter().all(|v| v.is_finite())) {
        return Err(CurvatureError::Degenerate(i));
    }
    let g = star_curvature(&std::array::from_fn(|k| Hyper::variable(q[k], k)));
    let g_hess = g.hessian();
    let g_hess = DMatrix::from_fn(7, 7, |r, c| g_hess[r][c]);
    let mut hess = jac.transpose() * (g_hess * &jac);
    for (slots, parts) in &pieces {
        // M = Σ_k ∂g/∂q_k ∇²_e q_k (6×6), then Eᵀ M E into the star's blocks.
        let mut m = [[0.0; 6]; 6];
        for (part, &weight) in parts.iter().zip(&g.grad) {
            for (row, part_row) in m.iter_mut().zip(part.hessian()) {
                for (v, h) in row.iter_mut().zip(part_row) {
                    *v += weight * h;
                }
            }
        }
        // Corner a ∈ {0, 1, 2} of the triangle sees e-block rows: corner 1 → e1 (+1),
        // corner 2 → e2 (+1), corner 0 → e1 and e2 (−1 each).
        let block = |a: usize, b: usize, r: usize, c: usize| -> f64 {
            let weights = |corner: usize| match corner {
                0 => [-1.0, -1.0],
                1 => [1.0, 0.0],
                _ => [0.0, 1.0],
            };
            let (wa, wb) = (weights(a), weights(b));
            let mut sum = 0.0;
            for (ea, &ka) in wa.iter().enumerate() {
                for (eb, &kb) in wb.iter().enumerate() {
                    if ka != 0.0 && kb != 0.0 {
                        sum += ka * kb * m[3 * ea + r][3 * eb + c];
                    }
                }
            }
            sum
        };
        for a in 0..3 {
            for b in 0..3 {
                for r in 0..3 {
                    for c in 0..3 {
                        hess[(slots[a] + r, slots[b] + c)] += block(a, b, r, c);
                    }
                }
            }
        }
    }
    if hess.iter().all(|v| v.is_finite()) {
        Ok((vertices, hess))
    } else {
        Err(CurvatureError::Degenerate(i))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmc::curvature::mean_curvature_gradient;
    use crate::cmc::generators::icosphere;
    use crate::cmc::testing::{has_obtuse, near_right_angle, perturbed, rng};

    /// Every entry of the Hessian against central differences of the exact gradient.
    #[test]
    fn curvature_hessian_matches_central_differences_of_the_gradient() {
        let mut rng = rng(17);
        let base = icosphere(1.0, 2, "skin").unwrap();
        let (mut tested, mut obtuse, mut worst) = (0, 0, 0.0f64);
        for trial in 0..4 {
            let mesh = perturbed(&base, 0.3, &mut rng);
            for v in (trial..mesh.vertex_count()).step_by(9) {
                if near_right_angle(&mesh, v, 1e-2) {
                    continue;
                }
                obtuse += usize::from(has_obtuse(&mesh, v));
                let (vertices, hess) = mean_curvature_hessian(&mesh, v).unwrap();
                assert!((&hess - hess.transpose()).amax() < 1e-9 * (1.0 + hess.amax()));
                for (b, &w) in vertices.iter().enumerate() {
                    for c in 0..3 {
                        let step = 1e-6;
                        let grad_at = |delta: f64| {
                            let mut pos = mesh.positions().to_vec();
                            pos[w][c] += delta;
                            let mut m = mesh.clone();
                            m.set_positions(pos).unwrap();
                            mean_curvature_gradient(&m, v).unwrap().1
                        };
                        let (plus, minus) = (grad_at(step), grad_at(-step));
                        for (a, ((u, gp), (u2, gm))) in plus.iter().zip(&minus).enumerate() {
                            assert_eq!((u, vertices[a]), (u2, *u2));
                            for r in 0..3 {
                                let fd = (gp[r] - gm[r]) / (2.0 * step);
                                let exact = hess[(3 * a + r, 3 * b + c)];
                                let err = (exact - fd).abs() / (1.0 + fd.abs());
                                worst = worst.max(err);
                                assert!(err < 1e-5, "vertex {v}: {exact} vs {fd}");
                            }
                        }
                    }
                }
                tested += 1;
            }
        }
        assert!(tested > 10 && obtuse > 2, "{tested} stars, {obtuse} obtuse");
        eprintln!("curvature Hessian: {tested} stars, worst relative error {worst:.2e}");
    }
}
