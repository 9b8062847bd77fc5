//! Variables held at a bound, and the diagonal augmentation that takes them out of the
//! convexification of an exact Hessian.
//!
//! A variable sits at a lower bound (`xᵢ = xlᵢ`) with the Lagrangian gradient
//! `∇ᵢL = ∇ᵢf + Σₖ λₖ ∂cₖ/∂xᵢ > 0` pushing it into that bound (multiplier `zᵢ = −∇ᵢL < 0` in the
//! QP convention `Hd + g + Aᵀλ + z = 0`), or at an upper bound with `∇ᵢL < 0`: the QP of the
//! next iteration is expected to keep it there (`dᵢ = 0`), and the second-order conditions ask
//! for positive curvature only on the other variables (Nocedal & Wright, 2nd ed., Thm. 12.6:
//! the critical cone of a strongly active bound has `dᵢ = 0`). Its row and column of H do
//! not matter for such a step, but an inertia test over all variables sees them: a concave
//! function of a variable sitting at its bound (a cost growing like √c from c = 0) forces a
//! shift `δI` of the whole Hessian that shortens every step.
//!
//! The bound `dᵢ ≥ dlᵢ` is the row `eᵢᵀd` of the QP; Debreu's lemma for it reads: if H is
//! positive definite on the variables not held, `H + γ Σ_{i held} eᵢeᵢᵀ ≻ 0` for γ large enough.
//! The term is `γ dᵢ²`, zero on every step that keeps the bound, so a QP solution with the
//! bound active is one of the unmodified H, with the same multipliers (the term's gradient
//! vanishes at dᵢ = 0). A held variable that the QP would release moves less (it has the
//! added curvature), and is free at the next iterate, where its multiplier changed sign.
//!
//! [`augment_lower`] adds, for the sparse QP (which tests the inertia itself), the diagonal
//! `γᵢ = s + Σⱼ|Hᵢⱼ|` (s = `max(1, maxⱼ|Hⱼⱼ|)`, the shift scale of `exact`) to each held row,
//! which makes it diagonally dominant by s; the dense path adds the held variables' unit rows
//! to the augmentation rows of `exact` (a Cholesky test picks γ there).

use nalgebra_sparse::CscMatrix;

/// Indices of the variables held at a bound: at it to within `1e-10·(1 + |bound|)` and pushed
/// into it by the Lagrangian gradient `grad_l` (see the module header). Scaled units.
pub fn held_at_bounds(x: &[f64], xl: &[f64], xu: &[f64], grad_l: &[f64]) -> Vec<usize> {
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-10 * (1.0 + b.abs());
    (0..x.len())
        .filter(|&i| {
            (xl[i].is_finite() && near(x[i], xl[i]) && grad_l[i] > 0.0)
                || (xu[i].is_finite() && near(x[i], xu[i]) && grad_l[i] < 0.0)
        })
        .collect()
}

/// `h + Σ_{i ∈ held} γᵢ eᵢeᵢᵀ` for a lower triangle `h` (row ≥ col) that stores every diagonal
/// entry (see [`super::assemble_sparse_lower`]), with `γᵢ = s + Σⱼ|Hᵢⱼ|`; the pattern is
/// unchanged.
pub fn augment_lower(h: &CscMatrix<f64>, held: &[usize]) -> CscMatrix<f64> {
    let n = h.nrows();
    let mut row_sums = vec![0.0; n];
    let mut scale = 1.0_f64;
    for (r, c, &v) in h.triplet_iter() {
        row_sums[r] += v.abs();
        if r != c {
            row_sums[c] += v.abs();
        } else {
            scale = scale.max(v.abs());
        }
    }
    let mut is_held = vec![false; n];
    for &i in held {
        is_held[i] = true;
    }
    let mut out = h.clone();
    let (offsets, rows, values) = out.csc_data_mut();
    for c in 0..n {
        for k in offsets[c]..offsets[c + 1] {
            if rows[k] == c && is_held[c] {
                values[k] += scale + row_sums[c];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::hessian::{assemble_dense, assemble_sparse_lower};

    #[test]
    fn held_variables_are_at_a_bound_with_the_right_sign() {
        let inf = f64::INFINITY;
        let x = [0.0, 0.0, 1.0, 1.0, 0.5, 0.0];
        let xl = [0.0, 0.0, 0.0, 0.0, 0.0, -inf];
        let xu = [1.0, 1.0, 1.0, 1.0, 1.0, inf];
        let g = [2.0, -2.0, -1.0, 1.0, 3.0, 1.0];
        // 0: lower, pushed in; 1: lower, pulled off; 2: upper, pushed in; 3: upper, pulled
        // off; 4: interior; 5: unbounded below.
        assert_eq!(held_at_bounds(&x, &xl, &xu, &g), vec![0, 2]);
    }

    #[test]
    fn augmentation_makes_held_rows_dominant_and_keeps_the_pattern() {
        // H = [[-5, 2], [2, 1]]: indefinite; holding variable 0 leaves the curvature 1 > 0 of
        // variable 1, and the augmented matrix is positive definite.
        let h = assemble_sparse_lower(2, &[0, 1, 1], &[0, 0, 1], &[-5.0, 2.0, 1.0]);
        let a = augment_lower(&h, &[0]);
        assert_eq!(a.col_offsets(), h.col_offsets());
        assert_eq!(a.row_indices(), h.row_indices());
        let t: Vec<_> = a.triplet_iter().map(|(r, c, &v)| (r, c, v)).collect();
        let (r, c, v): (Vec<_>, Vec<_>, Vec<_>) =
            t.iter()
                .fold((vec![], vec![], vec![]), |mut acc, &(r, c, v)| {
                    acc.0.push(r);
                    acc.1.push(c);
                    acc.2.push(v);
                    acc
                });
        // γ₀ = s + |−5| + |2| = 5 + 7 = 12.
        assert_eq!(v[0], 7.0);
        assert!(assemble_dense(2, &r, &c, &v).cholesky().is_some());
        assert_eq!(augment_lower(&h, &[]).values(), h.values());
    }
}
