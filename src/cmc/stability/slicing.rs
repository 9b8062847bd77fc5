//! Spectrum slicing: the smallest eigenvalues of a sparse symmetric K on the orthogonal
//! complement of a few orthonormal rows, from inertia counts (see the parent module).
//!
//! ```text
//!     count(σ) = ν₋([K − σI, Rᵀ; R, 0]) − b = #{λ of K on null(R) : λ < σ}
//!     λ_i = inf{σ : count(σ) ≥ i}, bracketed by bisection from the Gershgorin interval [−g, g]
//! ```
//! Every count is one sparse LDLᵀ factorization of the same pattern (the symbolic analysis is
//! done once). A bracket stops at width [`super::SLICING_TOLERANCE`]·g; the midpoint is
//! reported.

use nalgebra::DVector;

use super::{SLICING_TOLERANCE, Spectrum};
use crate::solver::kkt::{Equilibration, KktError, KktSolver, Regularization};

/// The bordered matrix of the module header with its values at σ = 0.
struct Bordered {
    solver: KktSolver,
    /// Values at σ = 0 (pattern order).
    base: Vec<f64>,
    /// Degrees of freedom (rows of K).
    n: usize,
    /// Border rows.
    b: usize,
}

impl Bordered {
    /// Assembles K from `entries` (both triangles; repeats add up) and the border rows.
    fn new(
        n: usize,
        entries: &[(usize, usize, f64)],
        basis: &[DVector<f64>],
    ) -> Result<Self, KktError> {
        let b = basis.len();
        let mut lower: Vec<(usize, usize, f64)> = entries
            .iter()
            .filter(|&&(i, j, _)| i >= j)
            .copied()
            .collect();
        for (q, row) in basis.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                if v != 0.0 {
                    lower.push((n + q, j, v));
                }
            }
        }
        let rows: Vec<usize> = lower.iter().map(|e| e.0).collect();
        let cols: Vec<usize> = lower.iter().map(|e| e.1).collect();
        let (solver, positions) = KktSolver::from_lower_triplets(n, b, &rows, &cols)?;
        let mut base = vec![0.0; solver.values().len()];
        for (&(_, _, v), &at) in lower.iter().zip(&positions) {
            base[at] += v;
        }
        Ok(Bordered { solver, base, n, b })
    }

    /// Eigenvalues of K on the complement of the rows below `sigma`.
    fn count(&mut self, sigma: f64) -> Result<usize, KktError> {
        let values = self.solver.values_mut();
        values.copy_from_slice(&self.base);
        for i in 0..self.n {
            let at = self.solver.diagonal_position(i);
            self.solver.values_mut()[at] -= sigma;
        }
        // Successive counts differ by a diagonal shift only: the last scaling starts the next.
        let inertia = self.solver.factor(Regularization {
            primal: 0.0,
            dual: 1e-12,
            equilibration: Equilibration::RuizFromLast,
            ..Regularization::default()
        })?;
        Ok(inertia.negative.saturating_sub(self.b))
    }
}

/// The `wanted` smallest eigenvalues of K (n×n, `entries` of both triangles) on the orthogonal
/// complement of the orthonormal `basis`, and how many lie below `−negative_tolerance·g`.
pub(super) fn smallest(
    n: usize,
    entries: &[(usize, usize, f64)],
    basis: &[DVector<f64>],
    wanted: usize,
    negative_tolerance: f64,
) -> Result<Spectrum, String> {
    let why = |e: KktError| format!("spectrum slicing failed: {e}");
    let mut row_sums = vec![0.0f64; n];
    for &(i, _, v) in entries {
        row_sums[i] += v.abs();
    }
    let g = row_sums.iter().fold(f64::MIN_POSITIVE, |m, &r| m.max(r));
    let mut bordered = Bordered::new(n, entries, basis).map_err(why)?;
    let free = n.saturating_sub(basis.len());
    let wanted = wanted.min(free);
    // Known counts (σ, count), ascending in σ; counts are non-decreasing in σ.
    let (low, high) = (-1.01 * g, 1.01 * g);
    let mut known = vec![(low, 0), (high, free)];
    let mut smallest = Vec::with_capacity(wanted);
    for i in 1..=wanted {
        // The bracket: the largest σ known with count < i, the smallest with count ≥ i.
        let mut lo = known
            .iter()
            .filter(|&&(_, c)| c < i)
            .fold(low, |m, &(s, _)| m.max(s));
        let mut hi = known
            .iter()
            .filter(|&&(_, c)| c >= i)
            .fold(high, |m, &(s, _)| m.min(s));
        while hi - lo > SLICING_TOLERANCE * g {
            let mid = 0.5 * (lo + hi);
            let c = bordered.count(mid).map_err(why)?;
            known.push((mid, c));
            if c >= i {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        smallest.push(0.5 * (lo + hi));
    }
    let negative = bordered.count(-negative_tolerance * g).map_err(why)?;
    Ok(Spectrum { smallest, negative })
}
