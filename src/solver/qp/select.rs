//! The one entry point through which the SQP solves every QP subproblem.
//!
//! It picks the method from the size and the Hessian representation ([`QpMethod`]): the dense
//! Goldfarb–Idnani method ([`super::dense`]) for n ≤ [`DENSE_LIMIT`] variables, warm-started
//! from the previous working set; the sparse primal-dual interior-point method
//! ([`super::sparse`]) above, with one [`SparseQp`] kept in the [`WarmStart`] so that its
//! symbolic analysis is reused by every QP of the same sparsity pattern. No n×n matrix is
//! formed on the sparse path: a `LowRank` Hessian stays in compact form, a `SparseLower` one
//! (possibly indefinite) is convexified by the sparse method's inertia correction, with the
//! shift schedule of `hessian::exact` (δ₀ = 1 relative growing ×100 when the previous QP needed
//! no shift, else from a third of the last shift growing ×8), so that both paths take the same
//! steps: a barely sufficient shift (IPOPT's δ₀ = 1e-4, meant for a barrier method) leaves
//! H + δI nearly singular along the null space of the constraints and gives long, poorly
//! modelled steps that the line search cuts to a few percent.
//!
//! On the dense path a `SparseLower` Hessian is densified and shifted by `δI` until its
//! Cholesky factorization exists, with δ growing geometrically from `1e-8·(1+max|Hᵢᵢ|)`; a
//! `LowRank` Hessian `δI − W M Wᵀ` is formed densely.
//!
//! A raised interrupt flag ([`WarmStart::interruptible`]) ends a solve with
//! [`QpStatus::Interrupted`]: at once on the dense path (polled before each dense solve), within
//! one interior-point iteration on the sparse one.
//!
//! The sparse method returns an interior solution: multipliers of inactive inequalities are
//! O(μ) rather than exactly 0, and the step is accurate to the relative tolerance passed
//! down, which the SQP sets two orders tighter than its own.

use std::borrow::Cow;
use std::fmt;

use nalgebra::DMatrix;
use nalgebra_sparse::{CooMatrix, CscMatrix};
use serde::{Deserialize, Serialize};

use super::dense::{self, ConstraintId};
use super::sparse::{Convexification, SparseQp};
use super::{QpHessian, QpProblem, QpSolution, QpStatus};
use crate::solver::Interrupt;

/// Variables above which [`QpMethod::Auto`] takes the sparse method.
pub const DENSE_LIMIT: usize = 2000;

/// First relative convexification shift of the sparse method when the previous QP needed
/// none (δ₀ of `hessian::exact`: no barrier curvature here, so a nearly singular H + δI must
/// not be passed on); a Hessian lacking curvature along a direction of recession is caught by
/// the unbounded-QP retry instead.
const SHIFT_FIRST: f64 = 1.0;
/// Growth of the first convexification search (κ̄⁺ of Wächter & Biegler 2006, §3.1).
const SHIFT_FIRST_GROWTH: f64 = 100.0;
/// Later searches start from the last shift times this (κ⁻) ...
const SHIFT_DECREASE: f64 = 1.0 / 3.0;
/// ... but not below this (δ_min, relative) ...
const SHIFT_MIN: f64 = 1e-10;
/// ... and grow by this (κ⁺).
const SHIFT_GROWTH: f64 = 8.0;

/// Which QP method solves the subproblems.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum QpMethod {
    /// Dense for n ≤ [`DENSE_LIMIT`], sparse above.
    #[default]
    Auto,
    /// Always the dense Goldfarb–Idnani method (forms n×n matrices).
    Dense,
    /// Always the sparse interior-point method.
    Sparse,
}

impl QpMethod {
    /// Whether QPs with `n` variables go to the sparse method.
    pub fn is_sparse(self, n: usize) -> bool {
        match self {
            QpMethod::Auto => n > DENSE_LIMIT,
            QpMethod::Dense => false,
            QpMethod::Sparse => true,
        }
    }
}

/// What is carried from one QP solve to the next: the working set of the dense method, or
/// the sparse solver with its symbolic analysis.
#[derive(Default)]
pub struct WarmStart {
    method: QpMethod,
    working_set: Vec<ConstraintId>,
    sparse: Option<Box<SparseQp>>,
    /// What the last sparse solve added to H (nothing on the dense path).
    convexification: Convexification,
    /// The last sparse shift relative to `max(1, maxⱼ|Hⱼⱼ|)`, where the next search starts.
    shift_memory: f64,
    /// The next sparse solve repeats the last shift (see [`WarmStart::snapshot`]).
    repeat_shift: bool,
    /// Smallest shift of the sparse solves (absolute; see [`WarmStart::set_shift_floor`]).
    shift_floor: f64,
    /// The run's interrupt flag, polled by every solve (module header).
    interrupt: Interrupt,
    /// The solver of [`WarmStart::newton_step`] (its own, so that its solves leave the main
    /// solver's state alone).
    newton: Option<Box<SparseQp>>,
    /// A dense Hessian and its Cholesky factor (see [`WarmStart::keep_factor`]).
    factored: Option<(DMatrix<f64>, DMatrix<f64>)>,
    /// The last dense solve's equality phase with that factor (see
    /// [`dense::solve_with_factor`]), dropped with the factor.
    equality_phase: Option<dense::EqualityPhase>,
}

impl fmt::Debug for WarmStart {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("WarmStart")
            .field("method", &self.method)
            .field("working_set", &self.working_set)
            .field("sparse", &self.sparse.is_some())
            .finish()
    }
}

impl WarmStart {
    /// An empty warm start for QPs solved by `method`.
    pub fn new(method: QpMethod) -> Self {
        WarmStart {
            method,
            ..WarmStart::default()
        }
    }

    /// The same warm start, its solves polling `interrupt` (module header).
    pub fn interruptible(mut self, interrupt: Interrupt) -> Self {
        self.interrupt = interrupt;
        self
    }

    /// Forgets the working set (for a QP of a different shape). The sparse solver's symbolic
    /// analysis is kept: it is redone by itself when the pattern changes.
    pub fn clear(&mut self) {
        self.working_set.clear();
    }

    /// The state to be put back with [`WarmStart::restore`] after a QP that must not carry
    /// over (a second-order correction). Until then, solves repeat the convexification of the
    /// last one: a correction of the same H and A must see the same `H + δI` as the step it
    /// corrects, or it is a step of another model.
    pub fn snapshot(&mut self) -> Snapshot {
        let saved = Snapshot {
            working_set: self.working_set.clone(),
            shift_memory: self.shift_memory,
            convexification: self.convexification.clone(),
        };
        self.repeat_shift = true;
        saved
    }

    /// What the last sparse solve added to a `SparseLower` Hessian (the step is that of
    /// `H + E`); nothing after a dense solve, which receives H already convexified.
    pub fn convexification(&self) -> &Convexification {
        &self.convexification
    }

    /// Sets the smallest convexification shift δ (absolute) of later sparse solves of a
    /// `SparseLower` Hessian: the SQP's damping of Newton steps that its line search had to cut
    /// (a Levenberg–Marquardt-like regularization; 0 switches it off).
    pub fn set_shift_floor(&mut self, floor: f64) {
        self.shift_floor = floor.max(0.0);
    }

    /// The current shift floor (see [`WarmStart::set_shift_floor`]).
    pub fn shift_floor(&self) -> f64 {
        self.shift_floor
    }

    /// Keeps the Cholesky factor L of the dense Hessian `h` (`h = L Lᵀ`, L in the lower
    /// triangle as nalgebra's `cholesky` computes it, the strict upper triangle ignored): a
    /// dense solve whose Hessian equals `h` entry for entry takes it instead of factoring
    /// again (the SQP's convexification has just factored the matrix in its definiteness test).
    pub fn keep_factor(&mut self, h: DMatrix<f64>, factor: DMatrix<f64>) {
        self.factored = Some((h, factor));
        self.equality_phase = None;
    }

    /// Puts back the state taken by [`WarmStart::snapshot`].
    pub fn restore(&mut self, saved: Snapshot) {
        self.working_set = saved.working_set;
        self.shift_memory = saved.shift_memory;
        self.convexification = saved.convexification;
        self.repeat_shift = false;
    }
}

impl WarmStart {
    /// The Newton step of the equality-constrained QP on the active set of `solution` (a sparse
    /// solution of `problem` after `identify_active_set`): its active bounds fixed, its
    /// active inequality rows made equalities, every other bound and row dropped, and H exactly
    /// as given, without convexification. `None` unless H passes the inertia test on that
    /// active set (positive definite on the null space of the active rows and bounds: the
    /// second-order condition of the QP) and the step keeps the dropped bounds and rows and the
    /// multipliers' signs (as `polish` checks); then the returned step is the QP's own
    /// solution with the exact H, and the convexification on record is none. One
    /// factorization: the reduced QP has no complementarity pairs. Sparse path with a
    /// `SparseLower` Hessian only.
    pub fn newton_step(
        &mut self,
        problem: &QpProblem,
        solution: &QpSolution,
        tolerance: f64,
    ) -> Option<QpSolution> {
        if !self.method.is_sparse(problem.g.len())
            || !matches!(problem.h, QpHessian::SparseLower(_))
            || solution.status != QpStatus::Optimal
        {
            return None;
        }
        let solver = self.newton.get_or_insert_with(|| {
            let mut solver = SparseQp::new();
            solver.exact_only = true;
            Box::new(solver)
        });
        solver.interrupt = self.interrupt.clone();
        let newton = solve_reduced(
            solver,
            problem,
            newton_problem(problem, solution),
            tolerance,
        )?;
        self.convexification = Convexification::default();
        Some(QpSolution {
            iterations: solution.iterations + newton.iterations,
            ..newton
        })
    }
}

/// Bounds of the equality-constrained QP of `solution`'s active set (see
/// [`WarmStart::newton_step`]): a bound or inequality row with a nonzero multiplier (after
/// `identify_active_set`) fixed at that bound, every other one dropped.
fn newton_problem(problem: &QpProblem, solution: &QpSolution) -> [Vec<f64>; 4] {
    let (dl, du) = fixed_at_active(problem.dl, problem.du, &solution.z);
    let (bl, bu) = fixed_at_active(problem.bl, problem.bu, &solution.lambda);
    [dl, du, bl, bu]
}

/// Bounds `[lower, upper]` with those of a negative multiplier fixed at the lower one, of a
/// positive multiplier at the upper one, fixed ones kept, and the others dropped (±∞).
fn fixed_at_active(lower: &[f64], upper: &[f64], multipliers: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mut fixed = (
        vec![f64::NEG_INFINITY; lower.len()],
        vec![f64::INFINITY; lower.len()],
    );
    for (k, ((&l, &u), &y)) in lower.iter().zip(upper).zip(multipliers).enumerate() {
        if l == u || y < 0.0 {
            (fixed.0[k], fixed.1[k]) = (l, l);
        } else if y > 0.0 {
            (fixed.0[k], fixed.1[k]) = (u, u);
        }
    }
    fixed
}

/// What [`WarmStart::snapshot`] saves.
#[derive(Debug, Clone)]
pub struct Snapshot {
    working_set: Vec<ConstraintId>,
    shift_memory: f64,
    convexification: Convexification,
}

/// Solves `problem`; `tolerance` is the relative KKT tolerance of the sparse method.
pub fn solve(problem: &QpProblem, warm: &mut WarmStart, tolerance: f64) -> QpSolution {
    let n = problem.g.len();
    if warm.interrupt.is_raised() {
        return interrupted(problem);
    }
    if warm.method.is_sparse(n) {
        let solver = warm.sparse.get_or_insert_with(|| Box::new(SparseQp::new()));
        solver.interrupt = warm.interrupt.clone();
        (solver.first_shift, solver.shift_growth) = if warm.repeat_shift && warm.shift_memory > 0.0
        {
            // Trial 0 fails again (same H and A), the remembered shift succeeds.
            (warm.shift_memory, SHIFT_GROWTH)
        } else if warm.shift_memory == 0.0 {
            (SHIFT_FIRST, SHIFT_FIRST_GROWTH)
        } else {
            (
                (SHIFT_DECREASE * warm.shift_memory).max(SHIFT_MIN),
                SHIFT_GROWTH,
            )
        };
        solver.min_shift = if matches!(problem.h, QpHessian::SparseLower(_)) {
            warm.shift_floor
        } else {
            0.0
        };
        let (mut solution, info) = solver.solve(problem, tolerance);
        warm.convexification = info.convexification;
        if let QpHessian::SparseLower(h) = problem.h {
            warm.shift_memory = warm.convexification.shift / max_diagonal(h).max(1.0);
            // The inertia correction makes the reduced Hessian non-singular, not positive
            // definite on every direction of recession: an exact Hessian without curvature
            // along a descent direction gives an unbounded QP. As on the dense path, the
            // Hessian is then shifted by δI, δ = 1 + max|Hᵢᵢ| growing ×100 (δ₀ = 1 relative, as
            // in `hessian::exact`).
            let base = 1.0 + max_diagonal(h);
            let mut shift = base;
            while matches!(solution.status, QpStatus::Unbounded | QpStatus::Numerical)
                && shift < 1e8 * base
            {
                let shifted = shifted_lower(h, shift);
                let retry = QpProblem {
                    h: QpHessian::SparseLower(&shifted),
                    ..*problem
                };
                let mut fresh = SparseQp::new();
                fresh.first_shift = SHIFT_FIRST;
                fresh.interrupt = warm.interrupt.clone();
                let (retried, info) = fresh.solve(&retry, tolerance);
                solution = retried;
                warm.convexification = Convexification {
                    shift: shift + info.convexification.shift,
                    ..info.convexification
                };
                shift *= 100.0;
            }
        }
        if solution.status == QpStatus::Optimal {
            if let Some(polished) = polish(problem, &solution, warm, tolerance) {
                solution = polished;
            }
            identify_active_set(problem, &mut solution, tolerance);
        }
        return solution;
    }
    let h = dense_hessian(&problem.h);
    warm.convexification = Convexification::default();
    let convexify = matches!(problem.h, QpHessian::SparseLower(_));
    let mut shift = 0.0;
    let base = 1e-8 * (1.0 + (0..n).map(|i| h[(i, i)].abs()).fold(0.0, f64::max));
    loop {
        if warm.interrupt.is_raised() {
            return interrupted(problem);
        }
        // h itself first; shifted copies only when it is not positive definite.
        let shifted = if shift == 0.0 {
            Cow::Borrowed(&*h)
        } else {
            let mut shifted = h.clone().into_owned();
            for i in 0..n {
                shifted[(i, i)] += shift;
            }
            Cow::Owned(shifted)
        };
        let shifted = &*shifted;
        // The kept matrix's entries compared as slices (the matrices' `==`, without its
        // iterator over entries).
        let factor = (warm.factored.as_ref())
            .filter(|(kept, _)| {
                kept.shape() == shifted.shape() && kept.as_slice() == shifted.as_slice()
            })
            .map(|(_, factor)| factor);
        let result = match factor {
            Some(factor) => dense::solve_with_factor(
                shifted,
                factor,
                problem,
                &warm.working_set,
                &mut warm.equality_phase,
            ),
            None => dense::solve(shifted, problem, &warm.working_set),
        };
        if result.solution.status == QpStatus::Numerical && convexify && shift < 1e20 {
            shift = if shift == 0.0 { base } else { shift * 10.0 };
            continue;
        }
        warm.working_set = result.working_set;
        return result.solution;
    }
}

/// The zero step of an interrupted solve of `problem`.
fn interrupted(problem: &QpProblem) -> QpSolution {
    let (n, m) = (problem.g.len(), problem.a.nrows());
    QpSolution {
        status: QpStatus::Interrupted,
        d: vec![0.0; n],
        lambda: vec![0.0; m],
        z: vec![0.0; n],
        iterations: 0,
    }
}

/// The bounds of `problem` with the active set of an interior-point `solution` imposed: bounds
/// and rows whose gap is at most their multiplier become equalities at that bound, inactive
/// rows become free. `None` when every active gap is already within the QP's accuracy.
fn active_set_problem(
    problem: &QpProblem,
    solution: &QpSolution,
    tolerance: f64,
) -> Option<[Vec<f64>; 4]> {
    let (mut dl, mut du) = (problem.dl.to_vec(), problem.du.to_vec());
    let (mut bl, mut bu) = (problem.bl.to_vec(), problem.bu.to_vec());
    let mut ambiguous = false;
    let mut fix = |value: f64, bound: f64, lo: &mut f64, hi: &mut f64| {
        ambiguous |= (value - bound).abs() > tolerance * (1.0 + bound.abs());
        (*lo, *hi) = (bound, bound);
    };
    for j in 0..dl.len() {
        let (l, u, d, z) = (dl[j], du[j], solution.d[j], solution.z[j]);
        if l == u {
            continue;
        }
        if z < 0.0 && d - l <= -z {
            fix(d, l, &mut dl[j], &mut du[j]);
        } else if z > 0.0 && u - d <= z {
            fix(d, u, &mut dl[j], &mut du[j]);
        }
    }
    let ad = problem.a * &nalgebra::DVector::from_column_slice(&solution.d);
    for i in 0..bl.len() {
        let (l, u, lambda) = (bl[i], bu[i], solution.lambda[i]);
        if l == u {
            continue;
        }
        if lambda < 0.0 && ad[i] - l <= -lambda {
            fix(ad[i], l, &mut bl[i], &mut bu[i]);
        } else if lambda > 0.0 && u - ad[i] <= lambda {
            fix(ad[i], u, &mut bl[i], &mut bu[i]);
        } else {
            (bl[i], bu[i]) = (f64::NEG_INFINITY, f64::INFINITY);
        }
    }
    ambiguous.then_some([dl, du, bl, bu])
}

/// Active-set polish of an interior-point solution whose active bounds are not yet reached to
/// the QP's accuracy (a degenerate QP: weakly active bounds with gap and multiplier both
/// O(√μ), which the interior-point method resolves only slowly and which would leave the SQP
/// iterate just off the bound, the dual residual at O(√μ)). The equality-constrained QP of the
/// identified active set is solved with the same convexification (valid: it has more
/// equality rows); its solution is taken when it keeps the other bounds and rows satisfied and
/// the multipliers' signs right, as an active-set method's would be.
fn polish(
    problem: &QpProblem,
    solution: &QpSolution,
    warm: &mut WarmStart,
    tolerance: f64,
) -> Option<QpSolution> {
    let bounds = active_set_problem(problem, solution, tolerance)?;
    let solver = warm.sparse.as_mut()?;
    solver.fixed_convexification = Some(warm.convexification.clone());
    let polished = solve_reduced(solver, problem, bounds, tolerance);
    solver.fixed_convexification = None;
    let polished = polished?;
    Some(QpSolution {
        iterations: solution.iterations + polished.iterations,
        ..polished
    })
}

/// `problem` with the bounds `[dl, du, bl, bu]` instead of its own, solved by `solver`; its
/// solution if it solves `problem` itself (see [`keeps_problem`]).
fn solve_reduced(
    solver: &mut SparseQp,
    problem: &QpProblem,
    [dl, du, bl, bu]: [Vec<f64>; 4],
    tolerance: f64,
) -> Option<QpSolution> {
    let reduced = QpProblem {
        dl: &dl,
        du: &du,
        bl: &bl,
        bu: &bu,
        ..*problem
    };
    let (solution, _) = solver.solve(&reduced, tolerance);
    (solution.status == QpStatus::Optimal
        && keeps_problem(problem, &[&dl, &du, &bl, &bu], &solution, tolerance))
    .then_some(solution)
}

/// Whether `polished`, the solution of the QP `problem` with the bounds `[dl, du, bl, bu]` (some
/// bounds fixed at the active ones, others kept or dropped), solves `problem` itself: the
/// bounds and rows not fixed hold (to `tolerance`, relative), and a fixed one's multiplier has
/// the sign of an active bound (to `√tolerance` of the gradient's scale).
fn keeps_problem(
    problem: &QpProblem,
    [dl, du, bl, bu]: &[&[f64]; 4],
    polished: &QpSolution,
    tolerance: f64,
) -> bool {
    let scale = 1.0 + problem.g.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let sign_slack = tolerance.sqrt() * scale;
    let within = |v: f64, l: f64, u: f64| {
        v >= l - tolerance * (1.0 + l.abs()) && v <= u + tolerance * (1.0 + u.abs())
    };
    for j in 0..dl.len() {
        let (v, z) = (polished.d[j], polished.z[j]);
        let ok = if dl[j] != du[j] || problem.dl[j] == problem.du[j] {
            within(v, problem.dl[j], problem.du[j])
        } else if dl[j] == problem.dl[j] {
            z <= sign_slack
        } else {
            z >= -sign_slack
        };
        if !ok {
            return false;
        }
    }
    let ad = problem.a * &nalgebra::DVector::from_column_slice(&polished.d);
    for i in 0..bl.len() {
        let (v, lambda) = (ad[i], polished.lambda[i]);
        let ok = if bl[i] != bu[i] || problem.bl[i] == problem.bu[i] {
            within(v, problem.bl[i], problem.bu[i])
        } else if bl[i] == problem.bl[i] {
            lambda <= sign_slack
        } else {
            lambda >= -sign_slack
        };
        if !ok {
            return false;
        }
    }
    true
}

/// Turns an interior-point solution into the form an active-set method returns, which the
/// SQP's termination test and penalty weights expect: a bound or row is taken as inactive when
/// its distance to the bound exceeds its multiplier (`gapⱼ > |zⱼ|`; at a strictly
/// complementary solution the multiplier is O(1) and the gap O(μ), at an inactive one the
/// reverse), and its multiplier, O(μ), is set to 0. An active variable bound is hit exactly
/// (d snapped onto it, so the iterate lands on the bound) only when the move is within the
/// QP's own accuracy, `gap ≤ tolerance·(1 + |bound|)`: at a degenerate solution (weakly active
/// bound, gap and multiplier both O(√μ)) a longer snap would break the linearized equalities
/// the step satisfies, and the SQP would stall at an infeasible point.
fn identify_active_set(problem: &QpProblem, solution: &mut QpSolution, tolerance: f64) {
    for j in 0..solution.d.len() {
        let (l, u, d, z) = (problem.dl[j], problem.du[j], solution.d[j], solution.z[j]);
        let (gap_l, gap_u) = (d - l, u - d);
        if z < 0.0 && gap_l <= -z {
            if gap_l <= tolerance * (1.0 + l.abs()) {
                solution.d[j] = l;
            }
        } else if z > 0.0 && gap_u <= z {
            if gap_u <= tolerance * (1.0 + u.abs()) {
                solution.d[j] = u;
            }
        } else if l != u {
            solution.z[j] = 0.0;
        }
    }
    let ad = problem.a * &nalgebra::DVector::from_column_slice(&solution.d);
    for (i, lambda) in solution.lambda.iter_mut().enumerate() {
        let (l, u) = (problem.bl[i], problem.bu[i]);
        if l == u {
            continue;
        }
        let gap = if *lambda < 0.0 { ad[i] - l } else { u - ad[i] };
        if gap > lambda.abs() {
            *lambda = 0.0;
        }
    }
}

/// max |Hᵢᵢ| of a lower triangle.
fn max_diagonal(h: &CscMatrix<f64>) -> f64 {
    h.triplet_iter()
        .filter(|(r, c, _)| r == c)
        .fold(0.0, |a, (_, _, v)| a.max(v.abs()))
}

/// H + δI as a lower triangle (diagonal entries added where the pattern lacks them).
fn shifted_lower(h: &CscMatrix<f64>, delta: f64) -> CscMatrix<f64> {
    let n = h.nrows();
    let mut coo = CooMatrix::new(n, n);
    for (r, c, &v) in h.triplet_iter() {
        coo.push(r, c, v);
    }
    for i in 0..n {
        coo.push(i, i, delta);
    }
    CscMatrix::from(&coo)
}

/// The Hessian as a dense symmetric matrix.
fn dense_hessian<'a>(h: &QpHessian<'a>) -> Cow<'a, DMatrix<f64>> {
    Cow::Owned(match *h {
        QpHessian::Dense(m) => return Cow::Borrowed(m),
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
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};

    /// min ½dᵀHd + gᵀd s.t. d₀ + d₁ ≥ 1, −1 ≤ d ≤ 1 with H given three ways.
    fn solve_with(h: QpHessian) -> QpSolution {
        solve_warm(h, &mut WarmStart::default())
    }

    /// [`solve_with`] from the warm start `warm`.
    fn solve_warm(h: QpHessian, warm: &mut WarmStart) -> QpSolution {
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
        solve(&problem, warm, 1e-9)
    }

    #[test]
    fn a_kept_factor_serves_only_its_own_matrix() {
        let h = DMatrix::from_row_slice(2, 2, &[3.0, 1.0, 1.0, 2.0]);
        let reference = solve_with(QpHessian::Dense(&h));
        // The factor of h gives the same solution to the bit.
        let mut warm = WarmStart::default();
        let factor = h.clone().cholesky().unwrap().unpack_dirty();
        warm.keep_factor(h.clone(), factor);
        let again = solve_warm(QpHessian::Dense(&h), &mut warm);
        assert_eq!(
            (again.d, again.lambda),
            (reference.d.clone(), reference.lambda.clone())
        );
        // A factor kept for another matrix is not used (it would give another step).
        let mut warm = WarmStart::default();
        let other = DMatrix::from_row_slice(2, 2, &[30.0, 0.0, 0.0, 20.0]);
        let wrong = other.clone().cholesky().unwrap().unpack_dirty();
        warm.keep_factor(other, wrong.clone());
        let again = solve_warm(QpHessian::Dense(&h), &mut warm);
        assert_eq!(
            (again.d, again.lambda),
            (reference.d.clone(), reference.lambda.clone())
        );
        let mut misused = WarmStart::default();
        misused.keep_factor(h.clone(), wrong);
        assert_ne!(
            solve_warm(QpHessian::Dense(&h), &mut misused).d,
            reference.d
        );
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

    /// min ½dᵀHd + gᵀd s.t. −1 ≤ d ≤ 1 with H = [[1, ½], [½, −1]] (indefinite): the sparse
    /// solve flips H₁₁, then the Newton step on its active set uses H itself.
    fn newton_after_flip(g: &[f64]) -> (QpSolution, Option<QpSolution>, Convexification) {
        let mut coo = CooMatrix::new(2, 2);
        coo.push(0, 0, 1.0);
        coo.push(1, 0, 0.5);
        coo.push(1, 1, -1.0);
        let h = CscMatrix::from(&coo);
        let a = CsrMatrix::zeros(0, 2);
        let problem = QpProblem {
            h: QpHessian::SparseLower(&h),
            g,
            a: &a,
            dl: &[-1.0, -1.0],
            du: &[1.0, 1.0],
            bl: &[],
            bu: &[],
        };
        let mut warm = WarmStart::new(QpMethod::Sparse);
        let convexified = solve(&problem, &mut warm, 1e-10);
        let flip = warm.convexification().clone();
        let newton = warm.newton_step(&problem, &convexified, 1e-10);
        (convexified, newton, flip)
    }

    #[test]
    fn newton_step_on_the_active_set_uses_the_exact_hessian() {
        // d₁ = −1 is active: on the rest (d₀ alone, curvature 1) H is positive definite, so the
        // step is the exact one, d₀ = ½, with the bound multiplier of H itself,
        // z₁ = −(½·½ + (−1)(−1) + 2) = −3.25 (the flipped H₁₁ = +1 gives −1.25).
        let (convexified, newton, flip) = newton_after_flip(&[0.0, 2.0]);
        assert!(!flip.is_zero());
        assert!(
            (convexified.z[1] + 1.25).abs() < 1e-6,
            "{:?}",
            convexified.z
        );
        let newton = newton.expect("H is convex on the active set");
        assert!((newton.d[0] - 0.5).abs() < 1e-9 && newton.d[1] == -1.0);
        assert!((newton.z[1] + 3.25).abs() < 1e-9 && newton.z[0].abs() < 1e-9);
    }

    #[test]
    fn newton_step_is_refused_where_the_active_set_leaves_negative_curvature_free() {
        // d₀ = 1 is active and d₁ (curvature −1) is free: no Newton step.
        let (convexified, newton, flip) = newton_after_flip(&[-5.0, 0.2]);
        assert!(!flip.is_zero());
        assert_eq!(convexified.d[0], 1.0);
        assert!(convexified.d[1].abs() < 1.0);
        assert!(newton.is_none());
    }

    #[test]
    fn degenerate_bound_is_reached_without_breaking_equalities() {
        // min ½(d₀² + (d₁ − 1)²) s.t. d₀ + d₁ = 1, d₀ ≥ 0: d = (0, 1) with a zero multiplier on
        // the active bound (weakly active), which an interior-point method approaches only as
        // √μ; the returned step must lie on the bound and satisfy the equality.
        let mut coo = CooMatrix::new(1, 2);
        coo.push(0, 0, 1.0);
        coo.push(0, 1, 1.0);
        let a = CsrMatrix::from(&coo);
        let h = CscMatrix::identity(2);
        let inf = f64::INFINITY;
        let problem = QpProblem {
            h: QpHessian::SparseLower(&h),
            g: &[0.0, -1.0],
            a: &a,
            dl: &[0.0, -inf],
            du: &[inf, inf],
            bl: &[1.0],
            bu: &[1.0],
        };
        let s = solve(&problem, &mut WarmStart::new(QpMethod::Sparse), 1e-8);
        println!("d = {:?}, z = {:?}, λ = {:?}", s.d, s.z, s.lambda);
        assert_eq!(s.status, QpStatus::Optimal);
        assert_eq!(s.d[0], 0.0);
        // The equality holds to the QP's relative tolerance (a snap by the O(√μ) gap broke it
        // by far more).
        assert!((s.d[0] + s.d[1] - 1.0).abs() <= 1e-8 * 2.0);
        assert!(s.z[0].abs() <= 1e-6 && s.lambda[0].abs() <= 1e-6);
    }
}
