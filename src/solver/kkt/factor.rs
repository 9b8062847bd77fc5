//! Numeric LDLᵀ factorization of the equilibrated KKT matrix, with static and dynamic
//! regularization, and the inertia read off the pivots.
//!
//! ```text
//!     S K S + diag(δ_p W_p, −δ_d W_d) = P L D Lᵀ Pᵀ,   W = diag(min(1, s_k²)),   inertia(K) = inertia(SKS) ≈ (#D>0, #D<0, #D=0)
//! ```
//! S = diag(s) > 0 by symmetric Ruiz equilibration: repeatedly `s_k ← s_k / √‖(SKS)_k,:‖∞`
//! until every row norm lies within [`RUIZ_TOLERANCE`] of 1 or [`RUIZ_PASSES`] passes are done,
//! starting from S = I or, on request, from the previous factorization's S ([`Equilibration`]).
//! Rows that are entirely zero keep s_k = 1. The weights W make the static regularization the
//! smaller of δ relative to the equilibrated matrix and δ absolute in K itself.
//! Dynamic regularization (as in Clarabel/QDLDL): a pivot with |d| ≤ `pivot_threshold` is
//! replaced by ±`pivot_replacement`, keeping its sign, and counted in [`Inertia::regularized`].

use faer::Par;
use faer::dyn_stack::MemStack;
use faer::linalg::cholesky::ldlt::factor::LdltRegularization;
use faer::sparse::SparseColMatRef;
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::cholesky::{SymbolicCholeskyRaw, supernodal};

use super::uplooking::ZeroPivot;
use super::{KktError, KktSolver};

/// The matrix values and regularization of the factorization currently held.
pub(super) struct FactoredValues {
    regularization: Regularization,
    values: Vec<f64>,
}

/// Maximum number of Ruiz equilibration passes.
const RUIZ_PASSES: usize = 20;
/// Equilibration stops when every nonzero row ∞-norm is within this of 1.
const RUIZ_TOLERANCE: f64 = 0.1;

/// Regularization applied during the numeric factorization: δ_p, δ_d relative to the
/// equilibrated matrix (rows of ∞-norm ≈ 1) and capped at the same absolute value in K.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Regularization {
    /// Added to every primal diagonal entry (δ_p ≥ 0).
    pub primal: f64,
    /// Subtracted from every dual diagonal entry (δ_d ≥ 0); > 0 makes K quasi-definite
    /// even with dependent or equality rows.
    pub dual: f64,
    /// Pivots with magnitude at or below this are replaced (0 disables).
    pub pivot_threshold: f64,
    /// Magnitude given to a replaced pivot.
    pub pivot_replacement: f64,
    /// How S is found.
    pub equilibration: Equilibration,
}

impl Default for Regularization {
    fn default() -> Self {
        Regularization {
            primal: 1e-9,
            dual: 1e-9,
            pivot_threshold: 1e-13,
            pivot_replacement: 1e-7,
            equilibration: Equilibration::Ruiz,
        }
    }
}

/// How the equilibrating diagonal S is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Equilibration {
    /// S = I: K itself is factored.
    Off,
    /// Ruiz passes from S = I.
    Ruiz,
    /// Ruiz passes from the last successful factorization's S (from I the first time). For a
    /// sequence of matrices whose scaling hardly changes, such as one matrix shifted along its
    /// diagonal (a spectrum slice, inertia trials), the first sweep then usually finds the rows
    /// balanced already; after a large change it can end at the pass limit less balanced than
    /// a start from I would.
    RuizFromLast,
}

/// Signs of the pivots of the last factorization.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Inertia {
    /// Positive pivots.
    pub positive: usize,
    /// Negative pivots.
    pub negative: usize,
    /// Pivots replaced by dynamic regularization (included in `positive`/`negative`).
    pub regularized: usize,
}

impl Inertia {
    /// True when the factored matrix has exactly `n_primal` positive and `n_dual` negative
    /// eigenvalues and no pivot needed replacing: the test of IPOPT-style inertia correction.
    pub fn is_quasi_definite_like(&self, n_primal: usize, n_dual: usize) -> bool {
        self.positive == n_primal && self.negative == n_dual && self.regularized == 0
    }
}

impl KktSolver {
    /// Factors `S K S + diag(δ_p W_p, −δ_d W_d)` numerically (no allocation; S from
    /// equilibration) and returns its inertia. When the values and `reg` are exactly those of
    /// the last successful factorization, its factors are kept (the result is the same bit for
    /// bit): an inertia test followed by the step's factorization of the same matrix, or a
    /// second-order correction of the same QP, costs one comparison of the values.
    pub fn factor(&mut self, reg: Regularization) -> Result<Inertia, KktError> {
        self.factor_using(reg, false)
    }

    /// [`KktSolver::factor`], by faer's own numeric factorization when `faer_only` (for the
    /// tests that compare the two) or when the analysis is supernodal, else by `uplooking`.
    fn factor_using(&mut self, reg: Regularization, faer_only: bool) -> Result<Inertia, KktError> {
        if self
            .last
            .as_ref()
            .is_some_and(|last| last.regularization == reg && last.values == self.values)
        {
            self.factored = true;
            return Ok(self.inertia);
        }
        self.factored = false;
        // The scale of the last successful factorization starts the equilibration.
        let warm = self.last.is_some();
        let mut last = self.last.take().unwrap_or_else(|| FactoredValues {
            regularization: reg,
            values: Vec::with_capacity(self.values.len()),
        });
        match reg.equilibration {
            Equilibration::Off => {
                self.scale.fill(1.0);
                self.shifted.copy_from_slice(&self.values);
            }
            Equilibration::Ruiz => self.equilibrate(false),
            Equilibration::RuizFromLast => self.equilibrate(warm),
        }
        for (k, &p) in self.diag_pos.iter().enumerate() {
            // min(relative, absolute): δ in the scaled matrix, but never more than δ in K.
            let weight = self.scale[k].powi(2).min(1.0);
            self.shifted[p] += weight
                * if k < self.n_primal {
                    reg.primal
                } else {
                    -reg.dual
                };
        }
        match (&self.analysis.up_looking, faer_only) {
            (Some(plan), false) => plan
                .factor(
                    &self.analysis.symbolic,
                    &self.shifted,
                    &mut self.l_values,
                    &mut self.up_looking_work,
                    &mut self.up_looking_filled,
                    reg.pivot_threshold,
                    reg.pivot_replacement,
                )
                .map_err(|ZeroPivot(index)| KktError::Breakdown(index))?,
            _ => self.factor_by_faer(reg)?,
        }
        let mut inertia = Inertia::default();
        let mut count = |d: f64| {
            if d > 0.0 {
                inertia.positive += 1;
            } else if d < 0.0 {
                inertia.negative += 1;
            }
            // faer replaces a small pivot by exactly ±pivot_replacement.
            if reg.pivot_threshold > 0.0 && d.abs() == reg.pivot_replacement {
                inertia.regularized += 1;
            }
        };
        match self.analysis.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(s) => {
                for &p in &s.col_ptr()[..self.dim] {
                    count(self.l_values[p]);
                }
            }
            SymbolicCholeskyRaw::Supernodal(s) => {
                let factor = supernodal::SupernodalLdltRef::new(s, &self.l_values);
                for k in 0..s.n_supernodes() {
                    let block = factor.supernode(k).val();
                    for j in 0..block.ncols() {
                        count(block[(j, j)]);
                    }
                }
            }
        }
        if inertia.positive + inertia.negative != self.dim {
            return Err(KktError::Breakdown(self.dim));
        }
        self.inertia = inertia;
        self.factored = true;
        self.numeric_factorizations += 1;
        last.regularization = reg;
        last.values.clear();
        last.values.extend_from_slice(&self.values);
        self.last = Some(last);
        Ok(inertia)
    }

    /// faer's numeric factorization of `shifted` into `l_values`.
    fn factor_by_faer(&mut self, reg: Regularization) -> Result<(), KktError> {
        let pattern = SymbolicSparseColMatRef::new_checked(
            self.dim,
            self.dim,
            &self.col_ptr,
            None,
            &self.row_idx,
        );
        let matrix = SparseColMatRef::new(pattern, &self.shifted);
        let regularization = LdltRegularization {
            dynamic_regularization_signs: None,
            dynamic_regularization_delta: reg.pivot_replacement,
            dynamic_regularization_epsilon: reg.pivot_threshold,
        };
        let stack = MemStack::new(&mut self.factor_mem);
        let result = self.analysis.symbolic.factorize_numeric_ldlt(
            &mut self.l_values,
            matrix,
            faer::Side::Lower,
            regularization,
            Par::Seq,
            stack,
            Default::default(),
        );
        if let Err(faer::linalg::cholesky::ldlt::factor::LdltError::ZeroPivot { index }) = result {
            return Err(KktError::Breakdown(index));
        }
        Ok(())
    }

    /// Computes the Ruiz scaling of `values` into `scale` and writes `S values S` into
    /// `shifted` (uses `residual` and `rhs_copy` as scratch), the passes starting from the S in
    /// `scale` when `warm` (see [`Equilibration::RuizFromLast`]), from I otherwise. Each sweep
    /// over the entries both applies a pass's factors and takes the next pass's row norms.
    fn equilibrate(&mut self, warm: bool) {
        if !warm || !self.scale.iter().all(|s| s.is_finite() && *s > 0.0) {
            self.scale.fill(1.0);
        }
        let KktSolver {
            col_ptr,
            row_idx,
            values,
            shifted,
            scale,
            residual: norms,
            rhs_copy: factors,
            ..
        } = self;
        norms.fill(0.0);
        for c in 0..col_ptr.len() - 1 {
            for p in col_ptr[c]..col_ptr[c + 1] {
                let r = row_idx[p];
                shifted[p] = values[p] * scale[r] * scale[c];
                let v = shifted[p].abs();
                norms[r] = norms[r].max(v);
                norms[c] = norms[c].max(v);
            }
        }
        for _ in 0..RUIZ_PASSES {
            let balanced = norms
                .iter()
                .all(|&n| n == 0.0 || (n - 1.0).abs() <= RUIZ_TOLERANCE);
            if balanced {
                break;
            }
            for ((s, f), &n) in scale.iter_mut().zip(factors.iter_mut()).zip(norms.iter()) {
                *f = if n > 0.0 && n.is_finite() {
                    1.0 / n.sqrt()
                } else {
                    1.0
                };
                *s *= *f;
            }
            norms.fill(0.0);
            for c in 0..col_ptr.len() - 1 {
                for p in col_ptr[c]..col_ptr[c + 1] {
                    let r = row_idx[p];
                    shifted[p] *= factors[r] * factors[c];
                    let v = shifted[p].abs();
                    norms[r] = norms[r].max(v);
                    norms[c] = norms[c].max(v);
                }
            }
        }
    }

    /// Inertia of the last successful factorization.
    pub fn inertia(&self) -> Inertia {
        self.inertia
    }
}

#[cfg(test)]
impl KktSolver {
    /// [`KktSolver::factor`] by faer's numeric factorization whatever the analysis, the
    /// factors held forgotten first (so that they are computed).
    pub(crate) fn factor_by_faer_only(&mut self, reg: Regularization) -> Result<Inertia, KktError> {
        self.last = None;
        self.factor_using(reg, true)
    }

    /// The factor's values (faer's layout).
    pub(crate) fn factor_values(&self) -> &[f64] {
        &self.l_values
    }

    /// True when the numeric factorization is `uplooking`'s.
    pub(crate) fn is_up_looking(&self) -> bool {
        self.analysis.up_looking.is_some()
    }

    /// True when the symbolic analysis chose the supernodal (blocked) factorization.
    pub(crate) fn is_supernodal(&self) -> bool {
        matches!(
            self.analysis.symbolic.raw(),
            SymbolicCholeskyRaw::Supernodal(_)
        )
    }
}
