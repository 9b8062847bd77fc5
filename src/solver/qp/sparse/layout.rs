//! Classification of the QP's bounds: which variables and rows have finite lower / upper
//! bounds, which variables are fixed (dl = du) and which rows are equalities or free.
//! Bounds of magnitude ≥ [`INFINITE_BOUND`] count as infinite (as in IPOPT, whose default
//! `nlp_upper_bound_inf` is 1e19), since a barrier on them would only slow convergence.

use crate::solver::qp::QpProblem;

/// Bound magnitude from which a bound is treated as absent.
pub const INFINITE_BOUND: f64 = 1e20;

/// True for a bound value that constrains anything.
pub fn is_finite_bound(v: f64) -> bool {
    v.abs() < INFINITE_BOUND
}

/// Lower/upper pair that no point satisfies (or NaN).
fn inconsistent(l: f64, u: f64) -> bool {
    l.is_nan() || u.is_nan() || l > u || l >= INFINITE_BOUND || u <= -INFINITE_BOUND
}

/// How a row of `bl ≤ A d ≤ bu` enters the interior-point method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RowKind {
    /// Both bounds infinite: the row is ignored (its multiplier is 0).
    Free,
    /// `bl = bu`: an equality with a free multiplier.
    Equality,
    /// At least one finite bound, `bl < bu`: an inequality with a slack s = A d.
    Inequality,
}

/// Bound structure of one QP.
#[derive(Debug, Default)]
pub struct Layout {
    /// Variable j has a finite lower bound (and is not fixed).
    pub var_lower: Vec<bool>,
    /// Variable j has a finite upper bound (and is not fixed).
    pub var_upper: Vec<bool>,
    /// Variable j is fixed at dl = du.
    pub fixed: Vec<bool>,
    /// Row kinds.
    pub row: Vec<RowKind>,
    /// Inequality row i has a finite lower bound.
    pub row_lower: Vec<bool>,
    /// Inequality row i has a finite upper bound.
    pub row_upper: Vec<bool>,
    /// Number of complementarity pairs (finite, non-fixed bounds).
    pub pairs: usize,
}

impl Layout {
    /// Classifies the bounds; `Err` when some bound pair is inconsistent (lower > upper, or an
    /// infinite value on the wrong side), i.e. the QP is trivially infeasible, or NaN.
    pub fn classify(&mut self, qp: &QpProblem<'_>) -> Result<(), ()> {
        let (n, m) = (qp.g.len(), qp.a.nrows());
        self.var_lower.clear();
        self.var_upper.clear();
        self.fixed.clear();
        self.row.clear();
        self.row_lower.clear();
        self.row_upper.clear();
        self.pairs = 0;
        for j in 0..n {
            let (l, u) = (qp.dl[j], qp.du[j]);
            if inconsistent(l, u) {
                return Err(());
            }
            let fixed = l == u;
            self.fixed.push(fixed);
            self.var_lower.push(!fixed && is_finite_bound(l));
            self.var_upper.push(!fixed && is_finite_bound(u));
        }
        for i in 0..m {
            let (l, u) = (qp.bl[i], qp.bu[i]);
            if inconsistent(l, u) {
                return Err(());
            }
            let kind = if l == u {
                RowKind::Equality
            } else if is_finite_bound(l) || is_finite_bound(u) {
                RowKind::Inequality
            } else {
                RowKind::Free
            };
            self.row.push(kind);
            let ineq = kind == RowKind::Inequality;
            self.row_lower.push(ineq && is_finite_bound(l));
            self.row_upper.push(ineq && is_finite_bound(u));
        }
        self.pairs = [
            &self.var_lower,
            &self.var_upper,
            &self.row_lower,
            &self.row_upper,
        ]
        .iter()
        .map(|flags| flags.iter().filter(|&&b| b).count())
        .sum();
        Ok(())
    }
}
