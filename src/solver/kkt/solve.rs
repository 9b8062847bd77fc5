//! Solves with the factored KKT matrix, refined iteratively against the unregularized K.
//!
//! ```text
//!     x₀ = (LDLᵀ)⁻¹ b,   r_k = b − K x_k,   x_{k+1} = x_k + (LDLᵀ)⁻¹ r_k
//! ```
//! Refinement stops when ‖r_k‖∞ ≤ tol·(1 + ‖b‖∞) or when a step fails to halve the residual
//! (refinement has stagnated at the accuracy the factors allow).

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::linalg::cholesky::LdltRef;
use faer::{Conj, MatMut, Par};

use super::{KktError, KktSolver};

/// Outcome of a refined solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SolveReport {
    /// Refinement steps taken (0 = the plain factor solve was accurate enough).
    pub refinement_steps: usize,
    /// Final ‖b − K x‖∞.
    pub residual: f64,
}

impl KktSolver {
    /// Solves `K x = b` in place (`rhs` holds b on entry, x on exit) with up to
    /// `max_refinement` refinement steps towards `‖b − Kx‖∞ ≤ tol·(1 + ‖b‖∞)`. No allocation.
    pub fn solve_refined(
        &mut self,
        rhs: &mut [f64],
        max_refinement: usize,
        tol: f64,
    ) -> Result<SolveReport, KktError> {
        if !self.factored {
            return Err(KktError::NotFactored);
        }
        let mut rhs_copy = std::mem::take(&mut self.rhs_copy);
        let mut residual = std::mem::take(&mut self.residual);
        rhs_copy.copy_from_slice(rhs);
        let b_norm = inf_norm(&rhs_copy);
        self.solve_factored(rhs);
        let mut report = SolveReport {
            refinement_steps: 0,
            residual: self.residual_into(&rhs_copy, rhs, &mut residual),
        };
        while report.refinement_steps < max_refinement && report.residual > tol * (1.0 + b_norm) {
            self.solve_factored(&mut residual);
            // residual now holds the correction dx; rhs_copy still holds b.
            for (x, dx) in rhs.iter_mut().zip(residual.iter()) {
                *x += *dx;
            }
            let new_residual = self.residual_into(&rhs_copy, rhs, &mut residual);
            report.refinement_steps += 1;
            let stalled = new_residual > 0.5 * report.residual;
            report.residual = new_residual;
            if stalled {
                break;
            }
        }
        self.rhs_copy = rhs_copy;
        self.residual = residual;
        Ok(report)
    }

    /// Solves `(K + S⁻¹ reg S⁻¹) x = b` in place with the factors only (no refinement).
    pub fn solve_factored(&mut self, rhs: &mut [f64]) {
        for (x, s) in rhs.iter_mut().zip(&self.scale) {
            *x *= s;
        }
        let factor = LdltRef::new(&self.analysis.symbolic, &self.l_values);
        let stack = MemStack::new(&mut self.solve_mem);
        let n = rhs.len();
        factor.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, n, 1),
            Par::Seq,
            stack,
        );
        for (x, s) in rhs.iter_mut().zip(&self.scale) {
            *x *= s;
        }
    }

    /// Solves `(K + S⁻¹ reg S⁻¹) X = B` in place for `columns` right-hand sides stored column-major in
    /// `rhs` (length dim × columns), with the factors only. The workspace grows on the first
    /// call with more columns than before, and is reused afterwards.
    pub fn solve_factored_columns(&mut self, rhs: &mut [f64], columns: usize) {
        if columns > self.solve_columns {
            self.solve_mem = MemBuffer::new(
                self.analysis
                    .symbolic
                    .solve_in_place_scratch::<f64>(columns, Par::Seq),
            );
            self.solve_columns = columns;
        }
        for column in rhs.chunks_exact_mut(self.dim) {
            for (x, s) in column.iter_mut().zip(&self.scale) {
                *x *= s;
            }
        }
        let factor = LdltRef::new(&self.analysis.symbolic, &self.l_values);
        let stack = MemStack::new(&mut self.solve_mem);
        factor.solve_in_place_with_conj(
            Conj::No,
            MatMut::from_column_major_slice_mut(rhs, self.dim, columns),
            Par::Seq,
            stack,
        );
        for column in rhs.chunks_exact_mut(self.dim) {
            for (x, s) in column.iter_mut().zip(&self.scale) {
                *x *= s;
            }
        }
    }

    /// `y ← K x` with the unregularized symmetric K (from its lower triangle).
    pub fn multiply(&self, x: &[f64], y: &mut [f64]) {
        y.fill(0.0);
        for c in 0..self.dim {
            let xc = x[c];
            let mut acc = 0.0;
            for p in self.col_ptr[c]..self.col_ptr[c + 1] {
                let r = self.row_idx[p];
                let v = self.values[p];
                y[r] += v * xc;
                if r != c {
                    acc += v * x[r];
                }
            }
            y[c] += acc;
        }
    }

    /// `r ← b − K x`, returning ‖r‖∞.
    fn residual_into(&self, b: &[f64], x: &[f64], r: &mut [f64]) -> f64 {
        self.multiply(x, r);
        let mut norm = 0.0f64;
        for (ri, bi) in r.iter_mut().zip(b) {
            *ri = bi - *ri;
            norm = norm.max(ri.abs());
        }
        norm
    }
}

fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}
