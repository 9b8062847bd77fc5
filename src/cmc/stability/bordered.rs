//! The bordered matrix of spectrum slicing and shift-invert (see the parent module):
//!
//! ```text
//!     B(σ) = [ K − σI   Rᵀ ]      ν₋(B(σ)) − b = #{λ of K on null(R) : λ < σ}
//!            [ R        0  ]      B(σ) [y; z] = [x; 0]  ⇒  y = (P(K − σI)P)⁻¹ x on null(R)
//! ```
//! One sparse LDLᵀ of a fixed pattern (the symbolic analysis done once) per shift σ.

use nalgebra::DVector;

use crate::solver::kkt::{Equilibration, KktError, KktSolver, Regularization};

/// The bordered matrix of the module header, factored at the last shift counted.
pub(super) struct Bordered {
    solver: KktSolver,
    /// Values at σ = 0 (pattern order).
    base: Vec<f64>,
    /// Degrees of freedom (rows of K).
    n: usize,
    /// Border rows.
    b: usize,
    /// Right-hand sides of [`Bordered::solve`], n + b per column.
    work: Vec<f64>,
}

impl Bordered {
    /// Assembles K from `entries` (both triangles; repeats add up) and the border rows.
    pub(super) fn new(
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
        Ok(Bordered {
            solver,
            base,
            n,
            b,
            work: Vec::new(),
        })
    }

    /// Factors B(σ) and returns the number of eigenvalues of K on the complement of the rows
    /// below `sigma`.
    pub(super) fn count(&mut self, sigma: f64) -> Result<usize, KktError> {
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

    /// Replaces each column x of `block` (n rows, column-major) by y of the module header,
    /// with the factors of the last [`Bordered::count`].
    pub(super) fn solve(&mut self, block: &mut [f64]) {
        let (n, dim) = (self.n, self.n + self.b);
        let columns = block.len() / n.max(1);
        self.work.clear();
        self.work.resize(dim * columns, 0.0);
        for (x, w) in block.chunks_exact(n).zip(self.work.chunks_exact_mut(dim)) {
            w[..n].copy_from_slice(x);
        }
        self.solver.solve_factored_columns(&mut self.work, columns);
        for (y, w) in block.chunks_exact_mut(n).zip(self.work.chunks_exact(dim)) {
            y.copy_from_slice(&w[..n]);
        }
    }
}

/// Gershgorin bound g ≥ max |λ(K)| from `entries` (both triangles; repeats add up).
pub(super) fn gershgorin(n: usize, entries: &[(usize, usize, f64)]) -> f64 {
    let mut row_sums = vec![0.0f64; n];
    for &(i, _, v) in entries {
        row_sums[i] += v.abs();
    }
    row_sums.iter().fold(f64::MIN_POSITIVE, |m, &r| m.max(r))
}
