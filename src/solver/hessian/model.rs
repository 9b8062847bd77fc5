//! The second-order model the SQP hands to its QP subproblems: dense BFGS, L-BFGS in
//! compact form, or the problem's exact Hessian (assembled and convexified by the SQP), with
//! the operations the outer loop needs (the QP representation, products H·d, resets).

use nalgebra::{DMatrix, DVector};
use nalgebra_sparse::{CscMatrix, CsrMatrix};

use super::{DenseBfgs, InertiaShift, Lbfgs, assemble_dense};
use crate::solver::qp::QpHessian;

/// The second-order model in use.
pub enum Model {
    /// Dense damped BFGS.
    Bfgs(DenseBfgs),
    /// Limited-memory BFGS.
    Lbfgs(Lbfgs),
    /// The problem's Hessian, assembled by the SQP at each iterate.
    Exact {
        /// The remembered inertia-correction shift.
        shift: InertiaShift,
        /// Dense convexified matrix (small n) or the raw lower triangle (large n).
        dense: Option<DMatrix<f64>>,
        /// Raw lower triangle for the sparse QP (large n).
        sparse: Option<CscMatrix<f64>>,
        /// Rows augmented into `dense`, their weights `γ/‖aₖ‖²` and whether they are
        /// equalities: the QP's multiplier of an active row k is short by `weight·aₖᵀd` (see
        /// [`super::Convexified::row_weight`]).
        row_weights: Vec<(usize, f64, bool)>,
        /// The inertia correction in `dense` (absolute, on top of the damping floor).
        inertia: f64,
    },
}

impl Model {
    pub fn qp_hessian(&self) -> QpHessian<'_> {
        match self {
            Model::Bfgs(b) => QpHessian::Dense(b.matrix()),
            Model::Lbfgs(l) => {
                let (delta, w, m) = l.compact();
                QpHessian::LowRank { delta, w, m }
            }
            Model::Exact { dense, sparse, .. } => match (dense, sparse) {
                (Some(d), _) => QpHessian::Dense(d),
                (None, Some(s)) => QpHessian::SparseLower(s),
                (None, None) => unreachable!("exact model is assembled before use"),
            },
        }
    }

    /// Dense copy for the elastic subproblems.
    pub fn dense(&self, n: usize) -> DMatrix<f64> {
        match self.qp_hessian() {
            QpHessian::Dense(d) => d.clone(),
            QpHessian::LowRank { delta, w, m } => {
                let mut d = -(w * m * w.transpose());
                for i in 0..n {
                    d[(i, i)] += delta;
                }
                d
            }
            QpHessian::SparseLower(s) => {
                let (r, c, v): (Vec<_>, Vec<_>, Vec<_>) = s
                    .triplet_iter()
                    .map(|(r, c, &v)| (r, c, v))
                    .fold((vec![], vec![], vec![]), |mut acc, (r, c, v)| {
                        acc.0.push(r);
                        acc.1.push(c);
                        acc.2.push(v);
                        acc
                    });
                let h = assemble_dense(n, &r, &c, &v);
                InertiaShift::default()
                    .convexify(&h)
                    .map(|(m, _)| m)
                    .unwrap_or_else(|| DMatrix::identity(n, n))
            }
        }
    }

    /// H·d.
    pub fn times(&self, d: &[f64]) -> Vec<f64> {
        let v = DVector::from_column_slice(d);
        match self.qp_hessian() {
            QpHessian::Dense(h) => (h * v).as_slice().to_vec(),
            QpHessian::LowRank { delta, w, m } => {
                (&v * delta - w * (m * w.tr_mul(&v))).as_slice().to_vec()
            }
            QpHessian::SparseLower(s) => {
                let mut out = vec![0.0; d.len()];
                for (r, c, &val) in s.triplet_iter() {
                    out[r] += val * d[c];
                    if r != c {
                        out[c] += val * d[r];
                    }
                }
                out
            }
        }
    }

    /// Adds back to the row multipliers of a QP solved with this model what the augmentation
    /// of an exact Hessian took from them (`a` the QP's rows, `d` its step): on equality rows,
    /// and on inequality rows active in the QP (λ̃ ≠ 0), where a restored value of the other
    /// sign becomes 0. An inequality row the QP left inactive keeps λ = 0: the augmentation's
    /// term only penalized moving off it, it is no force of the row.
    pub fn restore_multipliers(&self, lambda: &mut [f64], a: &CsrMatrix<f64>, d: &[f64]) {
        let Model::Exact { row_weights, .. } = self else {
            return;
        };
        for &(k, weight, equality) in row_weights {
            if !equality && lambda[k] == 0.0 {
                continue;
            }
            let restored = lambda[k] + weight * row_product(a, k, d);
            lambda[k] = if equality || restored * lambda[k] > 0.0 {
                restored
            } else {
                0.0
            };
        }
    }

    /// `dᵀ(γ·Σₖ uₖuₖᵀ)d`: the curvature the augmentation of an exact Hessian adds along d
    /// (0 for the other models).
    pub fn augmentation_curvature(&self, a: &CsrMatrix<f64>, d: &[f64]) -> f64 {
        let Model::Exact { row_weights, .. } = self else {
            return 0.0;
        };
        row_weights
            .iter()
            .map(|&(k, weight, _)| weight * row_product(a, k, d).powi(2))
            .sum()
    }

    pub fn is_quasi_newton(&self) -> bool {
        !matches!(self, Model::Exact { .. })
    }

    pub fn reset(&mut self) {
        match self {
            Model::Bfgs(b) => b.reset(),
            Model::Lbfgs(l) => l.reset(),
            Model::Exact { .. } => {}
        }
    }

    /// Restarts a quasi-Newton model at `factor·I` (shorter first steps); the exact Hessian
    /// is kept.
    pub fn reset_stiffer(&mut self, factor: f64) {
        match self {
            Model::Bfgs(b) => b.reset_scaled(factor),
            Model::Lbfgs(l) => l.reset_scaled(factor),
            Model::Exact { .. } => {}
        }
    }
}

/// `aₖᵀd` for row k of `a`.
fn row_product(a: &CsrMatrix<f64>, k: usize, d: &[f64]) -> f64 {
    let row = a.row(k);
    row.col_indices()
        .iter()
        .zip(row.values())
        .map(|(&j, v)| v * d[j])
        .sum()
}
