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
        /// Lower triangle for the sparse QP (large n), the held variables decoupled (see
        /// `held`); the QP convexifies it.
        sparse: Option<CscMatrix<f64>>,
        /// Rows augmented into `dense` and their weights `γ/‖aₖ‖²`: the QP's multiplier of row
        /// k is short by `weight·aₖᵀd` (see [`super::Convexified::row_weight`]).
        row_weights: Vec<(usize, f64)>,
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
    /// of an exact Hessian took from them (`a` the QP's rows, `d` its step).
    pub fn restore_multipliers(&self, lambda: &mut [f64], a: &CsrMatrix<f64>, d: &[f64]) {
        let Model::Exact { row_weights, .. } = self else {
            return;
        };
        for &(k, weight) in row_weights {
            let row = a.row(k);
            let ad: f64 = row
                .col_indices()
                .iter()
                .zip(row.values())
                .map(|(&j, v)| v * d[j])
                .sum();
            lambda[k] += weight * ad;
        }
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
