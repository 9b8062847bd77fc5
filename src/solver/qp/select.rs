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

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};

    /// min ½dᵀHd + gᵀd s.t. d₀ + d₁ ≥ 1, −1 ≤ d ≤ 1 with H given three ways.
    fn solve_with(h: QpHessian) -> QpSolution {
        let mut coo = CooMatrix::new(1, 2);
        coo.push(0, 0, 1.0);
        coo.push(0, 1, 1.0);
        let a = CsrMatrix::from(&coo);
        let problem = QpProblem {
            h,
            g: &[1.0, -0.5],
            a: &a,
            dl: &[-1.0, -1.0],
            du: &[1.0, 1.0],
            bl: &[1.0],
            bu: &[f64::INFINITY],
        };
        solve(&problem, &mut WarmStart::default(), 1e-9)
    }

    #[test]
    fn dense_sparse_and_low_rank_hessians_give_the_same_step() {
        // H = [[3, 1], [1, 2]] = 4I − W M Wᵀ with W = I, M = [[1, −1], [−1, 2]].
        let dense = DMatrix::from_row_slice(2, 2, &[3.0, 1.0, 1.0, 2.0]);
        let mut coo = CooMatrix::new(2, 2);
        coo.push(0, 0, 3.0);
        coo.push(1, 0, 1.0);
        coo.push(1, 1, 2.0);
        let lower = CscMatrix::from(&coo);
        let w = DMatrix::identity(2, 2);
        let m = DMatrix::from_row_slice(2, 2, &[1.0, -1.0, -1.0, 2.0]);
        let reference = solve_with(QpHessian::Dense(&dense));
        assert_eq!(reference.status, QpStatus::Optimal);
        for other in [
            solve_with(QpHessian::SparseLower(&lower)),
            solve_with(QpHessian::LowRank {
                delta: 4.0,
                w: &w,
                m: &m,
            }),
        ] {
            assert_eq!(other.status, QpStatus::Optimal);
            for (a, b) in other.d.iter().zip(&reference.d) {
                assert!((a - b).abs() < 1e-12);
            }
            assert!((other.lambda[0] - reference.lambda[0]).abs() < 1e-12);
        }
        // The constraint is active: d₀ + d₁ = 1 with a non-positive multiplier.
        assert!((reference.d[0] + reference.d[1] - 1.0).abs() < 1e-12);
        assert!(reference.lambda[0] < 0.0);
    }

    #[test]
    fn indefinite_sparse_hessian_is_convexified() {
        let mut coo = CooMatrix::new(2, 2);
        coo.push(0, 0, 1.0);
        coo.push(1, 1, -1.0);
        let lower = CscMatrix::from(&coo);
        let s = solve_with(QpHessian::SparseLower(&lower));
        assert_eq!(s.status, QpStatus::Optimal);
        assert!(s.d.iter().all(|v| v.abs() <= 1.0 + 1e-12));
    }
}
