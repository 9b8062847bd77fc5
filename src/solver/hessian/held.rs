//! Variables held at a bound, and how they are taken out of the convexification of an exact
//! Hessian.
//!
//! A variable sits at a lower bound (`xᵢ = xlᵢ`) with the Lagrangian gradient
//! `∇ᵢL = ∇ᵢf + Σₖ λₖ ∂cₖ/∂xᵢ > 0` pushing it into that bound (multiplier `zᵢ = −∇ᵢL < 0` in the
//! QP convention `Hd + g + Aᵀλ + z = 0`), or at an upper bound with `∇ᵢL < 0`: the QP of the
//! next iteration is expected to keep it there (`dᵢ = 0`). The second-order conditions ask for
//! positive curvature only on the other variables (Nocedal & Wright, 2nd ed., Thm. 12.6: the
//! critical cone of a strongly active bound has `dᵢ = 0`), but an inertia test over all
//! variables also sees the held ones: a concave function of a variable sitting at its bound (a
//! cost growing like √c from c = 0) forces a shift `δI` of the whole Hessian that shortens
//! every step.
//!
//! So the held variables B are decoupled: their rows and columns of H are replaced by
//! `s·eᵢeᵢᵀ` (s = `max(1, maxⱼ|Hⱼⱼ|)`, the shift scale of `exact`), leaving
//! ```text
//!     H̃ = [ H_FF  0  ]      F = the other variables
//!         [ 0    s·I ]
//! ```
//! A QP step that keeps the held bounds (d_B = 0) involves only H_FF: its d_F and row multipliers
//! λ are those of the unmodified H with these bounds active — the Newton step of the problem
//! restricted to the free variables, so the exact Hessian's fast local convergence is kept once
//! the active bounds are identified — and the inertia test concerns H_FF on the null space of
//! the rows, the second-order condition itself. Only the held bounds' own multipliers lose the
//! term `(H_BF d_F)`, an O(‖d‖) error that vanishes at a solution; a variable the QP releases
//! nonetheless moves with curvature s (a cautious step), and is free at the next iterate.
//!
//! The sparse QP path uses [`decouple_triplets`] (the same, on the triplets, with each held
//! variable's own curvature scale), and only near a feasible point (`Tuning::held_violation`):
//! at the gait ball collocation's fourth iterate (violation 2.2e2) eight variables held at
//! their bounds had to leave them by long steps, and the model without their couplings gave
//! QP multipliers of 9e7 where the coupled one gave 1e3 (the solve then Stalled instead of
//! Optimal in 6 iterations).

use nalgebra::DMatrix;

/// Lagrangian gradient (scaled; the solver's scaling keeps gradients ≤ 100, so this is 1e-6
/// of them, the default optimality tolerance) that counts as zero: a bound whose multiplier is
/// this small (weakly active) is held as well. A truss member idle at c = 0 sits there with
/// ∇L = ±2e-11 once the balance multipliers cancel the slope of its mass; held only on the
/// sign of that rounding, its Euler curvature at zero force (−250 against a reduced Hessian of
/// −0.1) forced a shift of the whole Hessian every other iteration. With 1e-8 the Michell
/// truss still toggled one such bound between held and free (shifts 1.7e-3 ↔ 5e-3, progress
/// stopped at optimality 2e-5: Acceptable, with `exact::FALLBACK_GAMMA` at 1e6); with 1e-4 it
/// converges (Optimal).
pub const WEAK_GRADIENT: f64 = 1e-4;

/// Indices of the variables held at a bound: at it to within `1e-10·(1 + |bound|)` and pushed
/// into it by the Lagrangian gradient `grad_l`, or not pulled off it by more than
/// `WEAK_GRADIENT` (see the module header). Scaled units.
pub fn held_at_bounds(x: &[f64], xl: &[f64], xu: &[f64], grad_l: &[f64]) -> Vec<usize> {
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-10 * (1.0 + b.abs());
    (0..x.len())
        .filter(|&i| {
            (xl[i].is_finite() && near(x[i], xl[i]) && grad_l[i] > -WEAK_GRADIENT)
                || (xu[i].is_finite() && near(x[i], xu[i]) && grad_l[i] < WEAK_GRADIENT)
        })
        .collect()
}

/// `h` (dense, symmetric) with the rows and columns of the held variables replaced by
/// `s·eᵢeᵢᵀ`.
pub fn decouple_dense(h: &DMatrix<f64>, held: &[usize]) -> DMatrix<f64> {
    let mut out = h.clone();
    if held.is_empty() {
        return out;
    }
    let scale = h.diagonal().iter().fold(1.0_f64, |a, v| a.max(v.abs()));
    for &i in held {
        out.row_mut(i).fill(0.0);
        out.column_mut(i).fill(0.0);
        out[(i, i)] = scale;
    }
    out
}

/// The Hessian triplets (lower or upper, as [`super::assemble_sparse_lower`] takes them) with
/// the rows and columns of the held variables replaced by `sᵢ·eᵢeᵢᵀ`, for the sparse QP path.
/// The entries removed stay as explicit zeros, so the pattern changes with the held set only
/// by the held diagonals. `sᵢ = max(1, largest |entry| of row i)`: the variable's own curvature
/// scale, rather than the whole Hessian's of [`decouple_dense`], so that a variable the QP
/// releases is not stiffened by the largest curvature of another part of the problem.
pub fn decouple_triplets(
    n: usize,
    rows: &[usize],
    cols: &[usize],
    values: &[f64],
    held: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let (mut r2, mut c2) = (rows.to_vec(), cols.to_vec());
    if held.is_empty() {
        return (r2, c2, values.to_vec());
    }
    let mut is_held = vec![false; n];
    for &i in held {
        is_held[i] = true;
    }
    let mut local = vec![1.0_f64; n];
    for ((&r, &c), &v) in rows.iter().zip(cols).zip(values) {
        local[r] = local[r].max(v.abs());
        local[c] = local[c].max(v.abs());
    }
    let mut v2: Vec<f64> = rows
        .iter()
        .zip(cols)
        .zip(values)
        .map(|((&r, &c), &v)| if is_held[r] || is_held[c] { 0.0 } else { v })
        .collect();
    for &i in held {
        r2.push(i);
        c2.push(i);
        v2.push(local[i]);
    }
    (r2, c2, v2)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::hessian::assemble_dense;

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
        // Weakly active (a multiplier below WEAK_GRADIENT): held; pulled off by more: free.
        let weak = [-1e-6, -1e-2, 1e-6, 1e-2, 0.0, 0.0];
        assert_eq!(held_at_bounds(&x, &xl, &xu, &weak), vec![0, 2]);
    }

    #[test]
    fn decoupled_triplets_match_the_dense_decoupling_up_to_the_held_scale() {
        let (r, c) = ([0, 1, 2, 1, 2, 2], [0, 0, 0, 1, 1, 2]);
        let v = [-5.0, 2.0, 1.0, 1.0, 0.5, 3.0];
        let (r2, c2, v2) = decouple_triplets(3, &r, &c, &v, &[0]);
        let sparse = assemble_dense(3, &r2, &c2, &v2);
        // Variable 0's own scale is its largest entry, |−5|; the free block is kept.
        let expected =
            DMatrix::from_row_slice(3, 3, &[5.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.5, 3.0]);
        assert_eq!(sparse, expected);
        // The removed entries stay in the pattern (explicit zeros).
        assert_eq!(r2.len(), r.len() + 1);
        let (_, _, same) = decouple_triplets(3, &r, &c, &v, &[]);
        assert_eq!(same, v.to_vec());
    }

    #[test]
    fn decoupling_keeps_the_free_block() {
        // H = [[-5, 2, 1], [2, 1, 0.5], [1, 0.5, 3]]: indefinite through variable 0; holding
        // it leaves the positive definite block of variables 1 and 2.
        let (r, c) = ([0, 1, 2, 1, 2, 2], [0, 0, 0, 1, 1, 2]);
        let v = [-5.0, 2.0, 1.0, 1.0, 0.5, 3.0];
        let full = assemble_dense(3, &r, &c, &v);
        let dense = decouple_dense(&full, &[0]);
        let expected =
            DMatrix::from_row_slice(3, 3, &[5.0, 0.0, 0.0, 0.0, 1.0, 0.5, 0.0, 0.5, 3.0]);
        assert_eq!(dense, expected);
        assert!(full.clone().cholesky().is_none() && dense.cholesky().is_some());
        assert_eq!(decouple_dense(&full, &[]), full);
    }
}
