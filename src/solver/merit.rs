//! The ℓ1 exact penalty merit function `φ(x) = f̃(x) + ρ·Σᵢ dist(c̃ᵢ(x), [c̃lᵢ, c̃uᵢ])` on the
//! scaled problem, and its penalty update (Nocedal & Wright, 2nd ed., §18.3 and §18.5).
//!
//! Why ℓ1 rather than SNOPT's augmented Lagrangian: the ℓ1 function needs no multiplier
//! estimates in the line search, it is exact for any ρ > ‖λ*‖∞, and its elastic QP (the
//! Sℓ1QP subproblem) is the same QP with ρ-weighted slack variables, so one penalty steers
//! both the merit function and elastic mode; its known weakness, the Maratos effect, is
//! cured by a second-order correction.

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

/// Merit value `f + ρ·v`.
pub fn merit(f: f64, violation: f64, rho: f64) -> f64 {
    f + rho * violation
}

/// The smallest penalty for which the step d is a descent direction of the merit function
/// with margin: ρ ≥ ‖λ‖∞ (exactness) and, when the linearized violation decreases by
/// `reduction > 0`, `gᵀd + ½dᵀHd ≤ (1 − 0.1)·ρ·reduction`, which gives
/// `D(φ; d) ≤ −½dᵀHd − 0.1·ρ·reduction`.
pub fn required_penalty(lambda_max: f64, gd: f64, dhd: f64, reduction: f64) -> f64 {
    let mut rho = lambda_max;
    if reduction > 0.0 {
        rho = rho.max((gd + 0.5 * dhd) / (0.9 * reduction));
    }
    rho
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn violation_of_two_sided_and_one_sided_rows() {
        let v = l1_violation(
            &[0.0, 3.0, -2.0, 1.0],
            &[1.0, f64::NEG_INFINITY, -1.0, 1.0],
            &[2.0, 2.5, f64::INFINITY, 1.0],
        );
        assert!((v - (1.0 + 0.5 + 1.0 + 0.0)).abs() < 1e-15);
    }

    #[test]
    fn penalty_gives_descent() {
        let (gd, dhd, red) = (3.0, 2.0, 0.5);
        let rho = required_penalty(1.0, gd, dhd, red);
        let slope = gd - rho * red;
        assert!(slope <= -0.5 * dhd - 0.1 * rho * red + 1e-12);
    }
}
