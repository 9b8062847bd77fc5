//! The one entry point through which the SQP solves every QP subproblem.
//!
//! It picks the method from the size and the Hessian representation: the dense
//! Goldfarb–Idnani method ([`super::dense`]) for small problems. Problems above
//! [`DENSE_LIMIT`] variables belong to the sparse interior-point method, which is not yet
//! part of this module: until it is, they are also densified here, so this path is for
//! n up to a few thousand only. A `SparseLower` Hessian (possibly indefinite: the sparse
//! method convexifies it by inertia correction) is densified and shifted by `δI` until its
//! Cholesky factorization exists, with δ growing geometrically from `1e-8·(1+max|Hᵢᵢ|)`.
//! A `LowRank` compact quasi-Newton Hessian `δI − W M Wᵀ` is formed densely on this path.

use nalgebra::DMatrix;

use super::dense::{self, ConstraintId};
use super::{QpHessian, QpProblem, QpSolution, QpStatus};

/// Variables above which the sparse method is meant to take over.
pub const DENSE_LIMIT: usize = 2000;

/// What is carried from one QP solve to the next: the working set of the dense method.
#[derive(Debug, Clone, Default)]
pub struct WarmStart {
    working_set: Vec<ConstraintId>,
}

impl WarmStart {
    /// Forgets the working set (for a QP of a different shape).
    pub fn clear(&mut self) {
        self.working_set.clear();
    }
}

/// Solves `problem`; `tolerance` is the optimality tolerance passed to iterative methods.
pub fn solve(problem: &QpProblem, warm: &mut WarmStart, _tolerance: f64) -> QpSolution {
    let h = dense_hessian(&problem.h);
    let n = problem.g.len();
    let convexify = matches!(problem.h, QpHessian::SparseLower(_));
    let mut shift = 0.0;
    let base = 1e-8 * (1.0 + (0..n).map(|i| h[(i, i)].abs()).fold(0.0, f64::max));
    loop {
        let mut shifted = h.clone();
        for i in 0..n {
            shifted[(i, i)] += shift;
        }
        let result = dense::solve(&shifted, problem, &warm.working_set);
        if result.solution.status == QpStatus::Numerical && convexify && shift < 1e20 {
            shift = if shift == 0.0 { base } else { shift * 10.0 };
            continue;
        }
        warm.working_set = result.working_set;
        return result.solution;
    }
}

/// The Hessian as a dense symmetric matrix.
fn dense_hessian(h: &QpHessian) -> DMatrix<f64> {
    match *h {
        QpHessian::Dense(m) => m.clone(),
        QpHessian::SparseLower(csc) => {
            let n = csc.nrows();
            let mut d = DMatrix::zeros(n, n);
            for (r, c, &v) in csc.triplet_iter() {
                d[(r, c)] += v;
                if r != c {
                    d[(c, r)] += v;
                }
            }
            d
        }
        QpHessian::LowRank { delta, w, m } => {
            let n = w.nrows();
            let mut d = -(w * m * w.transpose());
            for i in 0..n {
                d[(i, i)] += delta;
            }
            d
        }
    }
}
