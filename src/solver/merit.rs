//! The weighted ℓ1 exact penalty merit function on the scaled problem,
//! `φ(x) = f̃(x) + Σᵢ ρᵢ·dist(c̃ᵢ(x), [c̃lᵢ, c̃uᵢ])`, with Powell's update of the weights
//! (Powell 1978, "A fast algorithm for nonlinearly constrained optimization calculations";
//! the rule of SLSQP): `ρᵢ ← max(|λᵢ|, ½(ρᵢ + |λᵢ|))`.
//!
//! Why ℓ1 rather than SNOPT's augmented Lagrangian: the ℓ1 function needs no multiplier
//! estimates in the line search, it is exact once ρᵢ ≥ |λᵢ*|, and its elastic QP (the Sℓ1QP
//! subproblem) is the same QP with ρ-weighted slack variables, so one set of weights steers
//! both the merit function and elastic mode. Per-constraint weights that may decrease keep a
//! single large multiplier early on from freezing the steps later (an ℓ1 merit with one
//! monotone penalty took 10⁻⁵ steps on curved constraints). With ρᵢ ≥ |λᵢ| the QP step is a
//! descent direction: `D(φ; d) ≤ −dᵀHd` (Nocedal & Wright, 2nd ed., Theorem 18.2). Its known
//! weakness, the Maratos effect, is cured by a second-order correction in the line search.

/// Distance of `c` from the interval `[l, u]`.
pub fn row_violation(c: f64, l: f64, u: f64) -> f64 {
    (l - c).max(0.0) + (c - u).max(0.0)
}

/// ℓ1 norm of the constraint violations.
pub fn l1_violation(c: &[f64], cl: &[f64], cu: &[f64]) -> f64 {
    c.iter()
        .zip(cl.iter().zip(cu))
        .map(|(&c, (&l, &u))| row_violation(c, l, u))
        .sum()
}

/// `Σᵢ wᵢ·dist(cᵢ, [lᵢ, uᵢ])`.
pub fn weighted_violation(c: &[f64], cl: &[f64], cu: &[f64], w: &[f64]) -> f64 {
    c.iter()
        .zip(cl.iter().zip(cu))
        .zip(w)
        .map(|((&c, (&l, &u)), &w)| w * row_violation(c, l, u))
        .sum()
}

/// Powell's update of the penalty weights from the newest multipliers.
pub fn powell_update(weights: &mut [f64], lambda: &[f64]) {
    for (w, l) in weights.iter_mut().zip(lambda) {
        *w = l.abs().max(0.5 * (*w + l.abs()));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn violation_of_two_sided_and_one_sided_rows() {
        let (c, l, u) = (
            [0.0, 3.0, -2.0, 1.0],
            [1.0, f64::NEG_INFINITY, -1.0, 1.0],
            [2.0, 2.5, f64::INFINITY, 1.0],
        );
        assert!((l1_violation(&c, &l, &u) - 2.5).abs() < 1e-15);
        let w = [2.0, 1.0, 0.5, 7.0];
        assert!((weighted_violation(&c, &l, &u, &w) - 3.0).abs() < 1e-15);
    }

    #[test]
    fn powell_weights_follow_multipliers_and_decay_slowly() {
        let mut w = vec![0.0, 10.0];
        powell_update(&mut w, &[3.0, -1.0]);
        assert_eq!(w, vec![3.0, 5.5]);
        powell_update(&mut w, &[-4.0, 0.0]);
        assert_eq!(w, vec![4.0, 2.75]);
    }
}
