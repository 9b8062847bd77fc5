//! Elastic subproblems for when the linearized constraints are inconsistent.
//!
//! The elastic (Sℓ1QP) subproblem relaxes each row with non-negative slacks:
//! ```text
//!   min ½dᵀHd + gᵀd + ρ Σ (vᵢ + wᵢ) + ½ε Σ (vᵢ² + wᵢ²)
//!   s.t. bl ≤ A d + v − w ≤ bu,   dl ≤ d ≤ du,   v, w ≥ 0
//! ```
//! (vᵢ exists only where blᵢ is finite, wᵢ only where buᵢ is), which minimizes the quadratic
//! model of the ℓ1 merit function; the tiny ε > 0 keeps the Hessian positive definite for the
//! dual active-set method (it moves multipliers by ε·v, far below the tolerances).
//! The feasibility subproblem drops the objective: with H = εI and a box |d|∞ ≤ Δ it computes
//! the least linearized violation reachable, which measures how far x is from being a
//! stationary point of the violation (Byrd, Curtis & Nocedal 2010, steering rules).

use nalgebra::DMatrix;
use nalgebra_sparse::{CooMatrix, CsrMatrix};

use super::merit::{l1_violation, weighted_violation};
use super::qp::{self, QpHessian, QpProblem, QpSolution, QpStatus, WarmStart};

/// Regularization of the slack variables (and of d in the feasibility subproblem).
const SLACK_REGULARIZATION: f64 = 1e-8;

/// The linearization at one point: `A d` approximates the change of c.
pub struct Linearization<'a> {
    /// Jacobian (scaled), m×n.
    pub a: &'a CsrMatrix<f64>,
    /// Bounds on d.
    pub dl: &'a [f64],
    /// Bounds on d.
    pub du: &'a [f64],
    /// Bounds on A d: `cl − c`.
    pub bl: &'a [f64],
    /// Bounds on A d: `cu − c`.
    pub bu: &'a [f64],
}

impl Linearization<'_> {
    /// ℓ1 violation of the linearized rows after step d.
    pub fn violation_after(&self, d: &[f64]) -> f64 {
        let ad = self.a * &nalgebra::DVector::from_column_slice(d);
        l1_violation(ad.as_slice(), self.bl, self.bu)
    }

    /// ℓ1 violation at d = 0.
    pub fn violation_now(&self) -> f64 {
        let zero = vec![0.0; self.a.nrows()];
        l1_violation(&zero, self.bl, self.bu)
    }

    /// Weighted decrease of the linearized violation along d: `Σ wᵢ (vᵢ(0) − vᵢ(d))`.
    pub fn weighted_reduction(&self, d: &[f64], w: &[f64]) -> f64 {
        let ad = self.a * &nalgebra::DVector::from_column_slice(d);
        let zero = vec![0.0; self.a.nrows()];
        weighted_violation(&zero, self.bl, self.bu, w)
            - weighted_violation(ad.as_slice(), self.bl, self.bu, w)
    }
}

/// Solves the elastic subproblem with penalty weight `rho[i]` on the slacks of row i; returns
/// the solution restricted to d (length n) with the row multipliers of the original rows.
pub fn solve_elastic(
    h: &DMatrix<f64>,
    g: &[f64],
    lin: &Linearization,
    rho: &[f64],
    warm: &mut WarmStart,
    tolerance: f64,
) -> QpSolution {
    let he = extended_hessian(h, lin, SLACK_REGULARIZATION * (1.0 + h.diagonal().amax()));
    let (ae, slack_count) = extended_rows(lin);
    let n = g.len();
    let mut ge = g.to_vec();
    ge.extend(slack_columns(lin).iter().map(|&(row, _)| rho[row]));
    let (dl, du) = extended_bounds(lin.dl, lin.du, slack_count);
    let problem = QpProblem {
        h: QpHessian::Dense(&he),
        g: &ge,
        a: &ae,
        dl: &dl,
        du: &du,
        bl: lin.bl,
        bu: lin.bu,
    };
    let mut sol = qp::solve(&problem, warm, tolerance);
    sol.d.truncate(n);
    sol.z.truncate(n);
    sol
}

/// The least linearized ℓ1 violation reachable within `dl ≤ d ≤ du`, `|d|∞ ≤ radius`.
/// Returns None if the subproblem fails numerically.
pub fn least_violation(lin: &Linearization, radius: f64, tolerance: f64) -> Option<(f64, usize)> {
    let n = lin.dl.len();
    let h = DMatrix::identity(n, n) * SLACK_REGULARIZATION;
    let dl: Vec<f64> = lin.dl.iter().map(|&l| l.max(-radius)).collect();
    let du: Vec<f64> = lin.du.iter().map(|&u| u.min(radius)).collect();
    let boxed = Linearization {
        a: lin.a,
        dl: &dl,
        du: &du,
        bl: lin.bl,
        bu: lin.bu,
    };
    let g = vec![0.0; n];
    let mut warm = WarmStart::default();
    let ones = vec![1.0; lin.bl.len()];
    let sol = solve_elastic(&h, &g, &boxed, &ones, &mut warm, tolerance);
    (sol.status == QpStatus::Optimal).then(|| (boxed.violation_after(&sol.d), sol.iterations))
}

fn extended_hessian(h: &DMatrix<f64>, lin: &Linearization, eps: f64) -> DMatrix<f64> {
    let n = h.nrows();
    let k = slack_columns(lin).len();
    let mut he = DMatrix::zeros(n + k, n + k);
    he.view_mut((0, 0), (n, n)).copy_from(h);
    for i in n..n + k {
        he[(i, i)] = eps;
    }
    he
}

/// (row, sign) of each slack column: +1 for v (lower side), −1 for w (upper side).
fn slack_columns(lin: &Linearization) -> Vec<(usize, f64)> {
    let mut cols = Vec::new();
    for i in 0..lin.bl.len() {
        if lin.bl[i].is_finite() {
            cols.push((i, 1.0));
        }
        if lin.bu[i].is_finite() {
            cols.push((i, -1.0));
        }
    }
    cols
}

fn extended_rows(lin: &Linearization) -> (CsrMatrix<f64>, usize) {
    let (m, n) = (lin.a.nrows(), lin.a.ncols());
    let cols = slack_columns(lin);
    let mut coo = CooMatrix::new(m, n + cols.len());
    for (r, c, &v) in lin.a.triplet_iter() {
        coo.push(r, c, v);
    }
    for (k, &(row, sign)) in cols.iter().enumerate() {
        coo.push(row, n + k, sign);
    }
    (CsrMatrix::from(&coo), cols.len())
}

fn extended_bounds(dl: &[f64], du: &[f64], slacks: usize) -> (Vec<f64>, Vec<f64>) {
    let mut l = dl.to_vec();
    let mut u = du.to_vec();
    l.extend(std::iter::repeat_n(0.0, slacks));
    u.extend(std::iter::repeat_n(f64::INFINITY, slacks));
    (l, u)
}
