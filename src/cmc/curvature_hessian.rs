//! Exact Hessian of the discrete mean curvature `H_i` (seed eq. 5.2–5.3, [`super::curvature`])
//! w.r.t. the vertex and its 1-ring, by the chain rule through seven star sums.
//!
//! `H_i = g(q)` with `q = (L, N, A)` (7 numbers) and `g(L, N, A) = L·N / (4 A |N|)`, where each
//! of `L = Σ_t 2∇_{p0} a_t`, `N = Σ_t ½ (p1 − p0) × (p2 − p0)` and `A = Σ_t A_mixed(t, i)` is a
//! sum over the star triangles `t` (corners `p0 = x_i, p1, p2`, metres) of a function of that
//! triangle's nine coordinates. Hence
//! ```text
//!   ∇²H = Jᵀ (∇²g) J + Σ_k ∂g/∂q_k Σ_t P_tᵀ ∇²q_{k,t} P_t          (1/m³)
//! ```
//! with `J = ∂q/∂x` and `P_t` scattering a triangle's nine coordinates into the star's. The
//! per-triangle values, gradients and 9×9 Hessians of `q_{k,t}` and the 7×7 Hessian of `g` are
//! computed exactly (to rounding) with second-order forward-mode dual numbers
//! (`num_dual::Dual2SVec64`): no finite differences. The mixed area is piecewise smooth (Meyer's
//! obtuse rules switch at right angles); its Hessian is that of the active piece, consistent
//! with [`super::area::mixed_area_corner0`]'s gradient.

use nalgebra::{Const, DMatrix, SMatrix, SVector, U1};
use num_dual::{Derivative, Dual2SVec64, DualNum};

use super::area::corners_from;
use super::curvature::CurvatureError;
use super::mesh::Mesh;

type V3<T> = [T; 3];

fn sub<T: DualNum<Primitive = f64>>(a: &V3<T>, b: &V3<T>) -> V3<T> {
    [
        a[0].clone() - b[0].clone(),
        a[1].clone() - b[1].clone(),
        a[2].clone() - b[2].clone(),
    ]
}

fn cross<T: DualNum<Primitive = f64>>(a: &V3<T>, b: &V3<T>) -> V3<T> {
    [
        a[1].clone() * b[2].clone() - a[2].clone() * b[1].clone(),
        a[2].clone() * b[0].clone() - a[0].clone() * b[2].clone(),
        a[0].clone() * b[1].clone() - a[1].clone() * b[0].clone(),
    ]
}

fn dot<T: DualNum<Primitive = f64>>(a: &V3<T>, b: &V3<T>) -> T {
    a[0].clone() * b[0].clone() + a[1].clone() * b[1].clone() + a[2].clone() * b[2].clone()
}

/// The seven per-triangle pieces `(2∇_{p0} a, ½ (p1 − p0) × (p2 − p0), A_mixed(corner 0))` of a
/// triangle with corners `p0, p1, p2` given as nine coordinates.
fn triangle_pieces<T: DualNum<Primitive = f64>>(x: &[T; 9]) -> [T; 7] {
    let p = [0, 1, 2].map(|k| [x[3 * k].clone(), x[3 * k + 1].clone(), x[3 * k + 2].clone()]);
    let big_n = cross(&sub(&p[1], &p[0]), &sub(&p[2], &p[0])).map(|c| c * 0.5);
    let a = dot(&big_n, &big_n).sqrt();
    let n = big_n.clone().map(|c| c / a.clone());
    // 2∇_{p0} a = n̂ × e_0, e_0 = p2 − p1 (see super::area).
    let l = cross(&n, &sub(&p[2], &p[1]));
    let d = |m: usize| dot(&sub(&p[(m + 1) % 3], &p[m]), &sub(&p[(m + 2) % 3], &p[m]));
    let mixed = if d(0).re() < 0.0 {
        a * 0.5
    } else if d(1).re() < 0.0 || d(2).re() < 0.0 {
        a * 0.25
    } else {
        let u = sub(&p[0], &p[1]);
        let w = sub(&p[0], &p[2]);
        (dot(&u, &u) * d(2) + dot(&w, &w) * d(1)) / (a * 16.0)
    };
    let [l0, l1, l2] = l;
    let [n0, n1, n2] = big_n;
    [l0, l1, l2, n0, n1, n2, mixed]
}

/// `g(L, N, A) = L·N / (4 A |N|)`.
fn star_curvature<T: DualNum<Primitive = f64>>(q: &[T; 7]) -> T {
    let l = [q[0].clone(), q[1].clone(), q[2].clone()];
    let n = [q[3].clone(), q[4].clone(), q[5].clone()];
    dot(&l, &n) / (q[6].clone() * 4.0 * dot(&n, &n).sqrt())
}

/// Value, gradient and Hessian of `f` at `x` by second-order dual numbers.
fn second_order<const N: usize, const M: usize>(
    x: [f64; N],
    f: impl Fn(&[Dual2SVec64<N>; N]) -> [Dual2SVec64<N>; M],
) -> [(f64, SVector<f64, N>, SMatrix<f64, N, N>); M] {
    let duals: [Dual2SVec64<N>; N] = std::array::from_fn(|i| {
        let mut d = Dual2SVec64::<N>::from_re(x[i]);
        d.v1 = Derivative::derivative_generic(U1, Const::<N>, i);
        d
    });
    f(&duals).map(|r| {
        (
            r.re,
            r.v1.unwrap_generic(U1, Const::<N>).transpose(),
            r.v2.unwrap_generic(Const::<N>, Const::<N>),
        )
    })
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
    let mut jac = DMatrix::<f64>::zeros(7, dim);
    let mut pieces = Vec::new();
    for &t in mesh.vertex_triangles(i) {
        let (ids, p) = corners_from(mesh, t, i);
        let x: [f64; 9] = std::array::from_fn(|k| p[k / 3][k % 3]);
        let parts = second_order(x, triangle_pieces);
        let mut slots = [0; 3];
        for (slot, &v) in slots.iter_mut().zip(&ids) {
            *slot = local(v).ok_or(CurvatureError::Degenerate(i))?;
        }
        for (k, (value, grad, _)) in parts.iter().enumerate() {
            q[k] += value;
            for (c, g) in grad.iter().enumerate() {
                jac[(k, 3 * slots[c / 3] + c % 3)] += g;
            }
        }
        pieces.push((slots, parts));
    }
    let norm = (q[3] * q[3] + q[4] * q[4] + q[5] * q[5]).sqrt();
    if !(norm > 0.0 && q[6] > 0.0 && q.iter().all(|v| v.is_finite())) {
        return Err(CurvatureError::Degenerate(i));
    }
    let [(_, g_grad, g_hess)] = second_order(q, |q| [star_curvature(q)]);
    let g_hess = DMatrix::from_column_slice(7, 7, g_hess.as_slice());
    let mut hess = jac.transpose() * g_hess * &jac;
    for (slots, parts) in &pieces {
        for (k, (_, _, h)) in parts.iter().enumerate() {
            let weight = g_grad[k];
            for r in 0..9 {
                let row = 3 * slots[r / 3] + r % 3;
                for c in 0..9 {
                    hess[(row, 3 * slots[c / 3] + c % 3)] += weight * h[(r, c)];
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
