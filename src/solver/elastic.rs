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
//!
//! The extended Hessian keeps the representation of H, so no n×n matrix appears when H is
//! sparse or limited-memory: a dense H gets ε on the new diagonal entries, a sparse lower
//! triangle likewise. The compact form `δI − W M Wᵀ` has one diagonal scale δ for all
//! variables, so there each slack is scaled, v = σu with σ = √(δ/ε): the slack column of the
//! row becomes ±σ, its linear cost ρσ and its curvature δ, i.e. exactly ½ε v² again
//! (W gets zero rows). Row multipliers are unchanged by the substitution.

use nalgebra::DMatrix;
use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};

use super::merit::{l1_violation, row_violation};
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

    /// An upper bound on the least ℓ1 violation reachable within `|d|∞ ≤ radius` (and the
    /// bounds on d, which `step` must meet), from that one step: the ℓ1 violation of an affine
    /// map is convex, so `t·step` with `t = min(1, radius/‖step‖∞)` reaches at most
    /// `v(0) − t·(v(0) − v(step))`, and d = 0 reaches `v(0)`.
    pub fn violation_bound(&self, step: &[f64], radius: f64) -> f64 {
        let now = self.violation_now();
        let longest = step.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let inside = if longest > radius {
            radius / longest
        } else {
            1.0
        };
        (now - inside * (now - self.violation_after(step))).min(now)
    }

    /// Decrease of each row's linearized violation along d: `vᵢ(0) − vᵢ(d)`.
    pub fn row_reductions(&self, d: &[f64]) -> Vec<f64> {
        let ad = self.a * &nalgebra::DVector::from_column_slice(d);
        (0..self.bl.len())
            .map(|i| {
                row_violation(0.0, self.bl[i], self.bu[i])
                    - row_violation(ad[i], self.bl[i], self.bu[i])
            })
            .collect()
    }
}

/// Solves the elastic subproblem with penalty weight `rho[i]` on the slacks of row i; returns
/// the solution restricted to d (length n) with the row multipliers of the original rows.
pub fn solve_elastic(
    h: QpHessian,
    g: &[f64],
    lin: &Linearization,
    rho: &[f64],
    warm: &mut WarmStart,
    tolerance: f64,
) -> QpSolution {
    let n = g.len();
    let slacks = slack_columns(lin);
    let extended = ExtendedHessian::new(h, slacks.len());
    let scale = extended.slack_scale;
    let ae = extended_rows(lin, &slacks, scale);
    let mut ge = g.to_vec();
    ge.extend(slacks.iter().map(|&(row, _)| rho[row] * scale));
    let (dl, du) = extended_bounds(lin.dl, lin.du, slacks.len());
    let problem = QpProblem {
        h: extended.as_qp(),
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
pub fn least_violation(
    lin: &Linearization,
    radius: f64,
    warm: &mut WarmStart,
    tolerance: f64,
) -> Option<(f64, usize)> {
    let n = lin.dl.len();
    let mut h = CscMatrix::identity(n);
    h.values_mut().fill(SLACK_REGULARIZATION);
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
    let ones = vec![1.0; lin.bl.len()];
    let sol = solve_elastic(
        QpHessian::SparseLower(&h),
        &g,
        &boxed,
        &ones,
        warm,
        tolerance,
    );
    (sol.status == QpStatus::Optimal).then(|| (boxed.violation_after(&sol.d), sol.iterations))
}

/// H extended by k slack variables with curvature ε each, in H's own representation.
struct ExtendedHessian<'a> {
    kind: Extended<'a>,
    /// σ with v = σu (1 unless H is in compact form).
    slack_scale: f64,
}

enum Extended<'a> {
    Dense(DMatrix<f64>),
    Sparse(CscMatrix<f64>),
    LowRank {
        delta: f64,
        w: DMatrix<f64>,
        m: &'a DMatrix<f64>,
    },
}

impl<'a> ExtendedHessian<'a> {
    fn new(h: QpHessian<'a>, k: usize) -> Self {
        match h {
            QpHessian::Dense(h) => {
                let n = h.nrows();
                let eps = SLACK_REGULARIZATION * (1.0 + h.diagonal().amax());
                let mut he = DMatrix::zeros(n + k, n + k);
                he.view_mut((0, 0), (n, n)).copy_from(h);
                for i in n..n + k {
                    he[(i, i)] = eps;
                }
                ExtendedHessian {
                    kind: Extended::Dense(he),
                    slack_scale: 1.0,
                }
            }
            QpHessian::SparseLower(h) => {
                let n = h.nrows();
                let diag_max = h
                    .triplet_iter()
                    .filter(|(r, c, _)| r == c)
                    .fold(0.0_f64, |a, (_, _, v)| a.max(v.abs()));
                let eps = SLACK_REGULARIZATION * (1.0 + diag_max);
                let mut coo = CooMatrix::new(n + k, n + k);
                for (r, c, &v) in h.triplet_iter() {
                    coo.push(r, c, v);
                }
                for i in n..n + k {
                    coo.push(i, i, eps);
                }
                ExtendedHessian {
                    kind: Extended::Sparse(CscMatrix::from(&coo)),
                    slack_scale: 1.0,
                }
            }
            QpHessian::LowRank { delta, w, m } => {
                let (n, p) = w.shape();
                let eps = SLACK_REGULARIZATION * (1.0 + delta);
                let mut we = DMatrix::zeros(n + k, p);
                we.view_mut((0, 0), (n, p)).copy_from(w);
                ExtendedHessian {
                    kind: Extended::LowRank { delta, w: we, m },
                    slack_scale: (delta / eps).sqrt(),
                }
            }
        }
    }

    fn as_qp(&self) -> QpHessian<'_> {
        match &self.kind {
            Extended::Dense(h) => QpHessian::Dense(h),
            Extended::Sparse(h) => QpHessian::SparseLower(h),
            Extended::LowRank { delta, w, m } => QpHessian::LowRank {
                delta: *delta,
                w,
                m,
            },
        }
    }
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

/// [A, slack columns]: column n+k is `sign·scale` in its row.
fn extended_rows(lin: &Linearization, cols: &[(usize, f64)], scale: f64) -> CsrMatrix<f64> {
    let (m, n) = (lin.a.nrows(), lin.a.ncols());
    let mut coo = CooMatrix::new(m, n + cols.len());
    for (r, c, &v) in lin.a.triplet_iter() {
        coo.push(r, c, v);
    }
    for (k, &(row, sign)) in cols.iter().enumerate() {
        coo.push(row, n + k, sign * scale);
    }
    CsrMatrix::from(&coo)
}

fn extended_bounds(dl: &[f64], du: &[f64], slacks: usize) -> (Vec<f64>, Vec<f64>) {
    let mut l = dl.to_vec();
    let mut u = du.to_vec();
    l.extend(std::iter::repeat_n(0.0, slacks));
    u.extend(std::iter::repeat_n(f64::INFINITY, slacks));
    (l, u)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random `m`×`n` matrix (60 % of its entries nonzero) and a point `target` in the box
    /// `|d|∞ ≤ 4` that satisfies the rows: equalities (even rows) `A d = A·target`,
    /// inequalities `A·target ≤ A d ≤ A·target + s` (s ≥ 0 random), which d = 0 violates
    /// unless `A·target` happens to be 0.
    fn random_rows(
        rng: &mut ChaCha8Rng,
        n: usize,
        m: usize,
        target: &[f64],
    ) -> (CsrMatrix<f64>, Vec<f64>, Vec<f64>) {
        let mut coo = CooMatrix::new(m, n);
        let (mut bl, mut bu) = (Vec::new(), Vec::new());
        for i in 0..m {
            let mut centre = 0.0;
            for (j, &t) in target.iter().enumerate() {
                if rng.random_range(0.0..1.0) < 0.6 {
                    let v = rng.random_range(-2.0..2.0);
                    coo.push(i, j, v);
                    centre += v * t;
                }
            }
            bl.push(centre);
            bu.push(if i % 2 == 0 {
                centre
            } else {
                centre + rng.random_range(0.0..1.0)
            });
        }
        (CsrMatrix::from(&coo), bl, bu)
    }

    #[test]
    fn the_bound_from_one_step_holds_and_is_met_by_the_least_violation() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut below_now = 0;
        for trial in 0..40 {
            let (n, m) = (2 + trial % 4, 1 + trial % 5);
            let target: Vec<f64> = (0..n).map(|_| rng.random_range(-4.0..4.0)).collect();
            let (a, bl, bu) = random_rows(&mut rng, n, m, &target);
            let (dl, du) = (vec![-4.0; n], vec![4.0; n]);
            let lin = Linearization {
                a: &a,
                dl: &dl,
                du: &du,
                bl: &bl,
                bu: &bu,
            };
            // Every other trial a random step instead of one that meets the rows.
            let step: Vec<f64> = if trial % 2 == 0 {
                target.clone()
            } else {
                (0..n).map(|_| rng.random_range(-4.0..4.0)).collect()
            };
            let radius = rng.random_range(0.1..2.0);
            let bound = lin.violation_bound(&step, radius);
            let longest = step.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            // The scaled step reaches the convex combination or better, and d = 0 the current
            // violation ...
            let t = (radius / longest).min(1.0);
            let scaled: Vec<f64> = step.iter().map(|v| t * v).collect();
            let (now, after) = (lin.violation_now(), lin.violation_after(&step));
            let combination = (1.0 - t) * now + t * after;
            assert!(
                lin.violation_after(&scaled) <= combination + 1e-12,
                "trial {trial}"
            );
            assert!(
                (bound - combination.min(now)).abs() <= 1e-12,
                "trial {trial}"
            );
            below_now += usize::from(bound < now - 1e-9);
            // ... so the least violation within the radius is no larger.
            let mut warm = WarmStart::default();
            let (least, _) = least_violation(&lin, radius, &mut warm, 1e-10).expect("solved");
            assert!(
                least <= bound + 1e-7 * (1.0 + bound),
                "trial {trial}: {least} > {bound}"
            );
        }
        // The steps that meet the rows give bounds below the current violation.
        assert!(below_now >= 20, "{below_now} bounds below v");
    }
}
