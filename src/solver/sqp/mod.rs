//! The SQP outer loop: a line-search Sℓ1QP method (Fletcher 1985; Nocedal & Wright, 2nd ed.,
//! Algorithm 18.3 with §18.5), on the automatically scaled problem (see `evaluator`).
//!
//! Each major iteration at x (all quantities scaled, dimensionless):
//! 1. QP `min ½dᵀHd + ∇fᵀd  s.t. xl−x ≤ d ≤ xu−x, cl−c ≤ J d ≤ cu−c` through [`qp::solve`],
//!    warm-started from the previous working set; bounds on x are constraints of the QP, so
//!    every iterate satisfies them exactly.
//! 2. Elastic mode (see `elastic`) when that QP is inconsistent or its constraint forces
//!    `|λᵢ|·‖∇cᵢ‖` exceed [`Tuning::elastic_weight`] times the objective gradient (a nearly
//!    inconsistent linearization). The least reachable linearized violation is computed
//!    first; when it improves on the current violation by less than `tolerance` relative,
//!    x is a stationary point of the violation: the solve ends `Infeasible`, unless an earlier
//!    iterate was clearly less violated, in which case it returns there once more with a
//!    stiffer model (at most [`Tuning::max_retreats`] times). Otherwise the elastic weights are
//!    raised ×10 until the step achieves a tenth of the reachable reduction (steering).
//! 3. Termination tests at x with the QP multipliers (see `termination`); a feasible x with
//!    f < −1e20 or ‖x‖∞ > 1e10 ends the solve `Unbounded`. Before the QP of step 1, the
//!    optimality test is tried with the multipliers of the QP whose step reached x (as SNOPT
//!    and filterSQP do): the KKT measures are a certificate whatever multipliers they are given
//!    (wrong signs show as complementarity), so a point they pass is optimal, and the QP that
//!    would only confirm it (one factorization, one solve: a third of the QPs of a
//!    three-iteration cmc round) is skipped. The test costs one Jᵀλ product.
//!    A caller that follows the solve with a change of model (the truss clean-up rounds) may
//!    ask for a creep end, `SlowProgress`: near feasibility, the objective falling by less than
//!    `Options::progress_tolerance` over `Options::progress_window` iterations, or
//!    (`Options::progress_stretch` = s) its decrease over the last s iterations at most half
//!    that over the s before and below the tolerance: a geometric tail with ratio ≤ ½ per
//!    stretch has less than the last stretch's decrease left; or (`Options::progress_extrapolate`)
//!    the two stretches' decreases, continued geometrically over the next window, within the
//!    tolerance. Cost: 2s + 1 stored objectives.
//! 4. Weights ρᵢ of the ℓ1 merit `φ = f + Σ ρᵢ viol(cᵢ)`: Powell's update from the QP
//!    multipliers, raised where needed so the linearized violation decrease pays for the
//!    model's objective change (see `merit`).
//! 5. Backtracking Armijo line search on φ (η = 1e-4, safeguarded quadratic interpolation),
//!    starting no further than [`Tuning::step_limit`]·(1 + ‖x‖∞) away. If the unit step is
//!    rejected, one second-order correction (N&W eq. 18.51) re-solves the QP with the constraint
//!    bounds shifted by `c(x+d) − c(x) − J d`, against the Maratos effect. Steps whose predicted
//!    merit decrease comes mostly from the violation (and elastic steps) must also decrease
//!    the violation itself. With the exact Hessian no trial point may multiply the violation
//!    by more than [`Tuning::violation_growth`] (above [`Tuning::violation_floor`]). A failed or
//!    non-finite evaluation at a trial point only shortens the step; `EvalError::Fatal` ends the
//!    solve with `EvaluationError`.
//!    Under [`Globalization::TrustRegion`] (Fletcher's Sℓ1QP proper) the QP's step box is
//!    intersected with an ℓ∞ radius instead, and the step is accepted or rejected by the ratio
//!    of the merit's actual to predicted decrease (see `trust_region_step`); a QP that fails
//!    is retried with a fresh quasi-Newton model, then with smaller radii.
//! 6. Hessian update (damped BFGS / L-BFGS) or exact Hessian at the new point with the new
//!    multipliers λ = λ_QP (initial multipliers: least squares, for the exact Hessian). An
//!    exact-Hessian solve whose line search fails, or whose penalty weights stay above
//!    `Tuning::exact_weight_limit` for `Tuning::exact_patience` iterations (curvature scaled by
//!    diverging multipliers freezes the steps), continues with the quasi-Newton model instead. On
//!    the dense path the variables held at a bound by the Lagrangian gradient are decoupled from
//!    the exact Hessian before it is convexified (see `hessian::held`), so that a negative
//!    curvature along them (which the bound blocks) does not shift the whole Hessian. On the
//!    sparse path only at points violating no constraint by more than `Tuning::held_violation`: far
//!    from feasibility the held set predicts little (the gait ball collocation's QPs failed).
//!    The QP multipliers of void rows (no Jacobian entry above `multipliers::VOID_ROW`) are
//!    set to 0 (see `multipliers::clear_void_rows`).
//! 7. Newton endgame (exact Hessian, sparse path, line search): the sparse QP convexifies an
//!    indefinite H (`H + E`, negative-diagonal flip and shift), and near a solution E, not H,
//!    can set the step: a flip on a variable whose negative curvature the constraints cover
//!    leaves an error propagator `(H + E)⁻¹E` along directions of small true curvature, a
//!    linear rate of ×0.983 per iteration over hundreds of full steps on
//!    `through_deck_cantilever.toml`. So when the QP's active set (the signs of its bound and
//!    row multipliers) is the one of the last [`Tuning::endgame_after`] QPs, or the last step
//!    was such a Newton step taken in full, and no damping floor is in effect, the step is
//!    the Newton step of the equality-constrained QP on that active set with H itself
//!    (`qp::WarmStart::newton_step`), provided H passes the inertia test there (the
//!    second-order condition on the active set) and the step keeps the other bounds, rows and
//!    multiplier signs. Its second-order correction is solved on the same active set (a
//!    correction of the convexified QP is a step of another model, and the line search
//!    refused the Newton steps for their second-order violation). A Newton step that the line
//!    search refuses is replaced by the convexified QP's step at the same point. Cost: one
//!    more factorization per iteration on a stable active set (the reduced QP has no
//!    complementarity pairs), against the 10–30 of the interior-point QP.
//!
//! Hessian choice in `HessianMode::Auto`: the exact Hessian when the problem has one; else
//! dense BFGS for n ≤ [`Tuning::dense_bfgs_limit`] (an n×n update costs O(n²) per iteration and the
//! dense QP O(n³) anyway), L-BFGS above. `HessianMode::Exact` on a problem without a Hessian
//! makes the same quasi-Newton choice. `HessianMode::Bfgs` above [`qp::DENSE_LIMIT`] variables
//! is served by L-BFGS (no n×n matrix on the large-problem path).
//!
//! QP method ([`Options::qp_method`], see `qp::select`): the dense active-set method up to
//!
//! Files, one per phase of an iteration: `state` (the iterate and the loop's memory, the start,
//! retreats), `step` (the QP and elastic mode), `penalty` (merit weights and the step's predicted
//! descent), `line_search`, `trust_region`, `model` (Hessian updates) and `finish` (termination
//! tests, the log record, the solution). [`Sqp::run`] calls one method per phase and takes every
//! decision through [`Next`].

mod finish;
mod jacobian;
mod line_search;
mod model;
mod penalty;
mod state;
mod step;
mod trust_region;

use std::cell::RefCell;
use std::ops::ControlFlow;
use std::sync::Arc;
use std::time::Instant;

use nalgebra_sparse::CsrMatrix;

use super::evaluator::{Evaluator, Values};
use super::hessian::{DenseBfgs, InertiaShift, Lbfgs, Model};
use super::log;
use super::merit;
use super::qp::{self, QpMethod, QpStatus, WarmStart};
use super::termination::Kkt;
use super::{
    Globalization, HessianMode, Interrupt, Interruptible, IterationRecord, Nlp, Options, Solution,
    Status, Tuning,
};
use jacobian::Jacobian;
use line_search::LineSearch;
use penalty::Descent;
use state::State;
use step::StepChoice;

struct Sqp<'a> {
    ev: Evaluator<'a>,
    options: &'a Options,
    /// The method's constants (`options.tuning`).
    tuning: &'a Tuning,
    started: Instant,
    log: Vec<IterationRecord>,
    /// What of the log is shown live (`options.log`; a status line for long runs on a terminal).
    live: RefCell<log::LiveLog>,
    model: Model,
    /// Penalty weights of the merit function, one per row.
    rho: Vec<f64>,
    lambda: Vec<f64>,
    /// ‖λ‖∞ of the last QP's multipliers, or of the initial least-squares multipliers before
    /// the first QP (see [`MULTIPLIER_JUMP`]).
    last_qp_multipliers: f64,
    warm: WarmStart,
    elastic_warm: WarmStart,
    /// For the least-violation subproblems (their own shape, so their own sparse analysis).
    feasibility_warm: RefCell<WarmStart>,
    /// The constraint Jacobian's entries and CSR layout.
    jac_pattern: Jacobian,
    /// The QP method in effect ([`Options::qp_method`], with `Auto` resolved for exact
    /// Hessians above [`Tuning::exact_sparse_limit`]).
    qp_method: QpMethod,
    /// ℓ∞ trust-region radius on the step (unscaled variables; infinite under the line search,
    /// and at most [`Tuning::step_limit`]·(1 + ‖x‖∞) in effect).
    radius: f64,
    /// Signs of the last QP's bound and row multipliers (its active set), and for how many QPs
    /// before it they were the same (see `endgame_due`).
    active_signature: Vec<i8>,
    active_stable: usize,
    /// When this iteration's step is a Newton step on the active set (see `endgame_due`): the
    /// convexified QP's solution whose active set it used.
    newton_base: Option<qp::QpSolution>,
    /// The last step was such a Newton step, taken in full: the next one is due whatever the
    /// active set's history.
    endgame: bool,
    /// A Newton step on the active set failed its line search at the current point.
    endgame_refused: bool,
    /// The exact Hessian at the current point is still to be evaluated (see
    /// `update_model`): before the next QP, unless the solve ends on arrival.
    hessian_due: bool,
}

/// What an iteration decided; the loop acts on nothing else.
enum Next {
    /// A new point was accepted after a step of length α; the next iteration starts there.
    Accept(f64),
    /// The iteration is repeated, at the same point or (after a retreat) at the least violated
    /// one, with a changed model, radius or penalty weights.
    Retry,
    /// The solve ends with this status at the current point, with the QP multipliers.
    Finish(Status),
}

/// Solves `nlp` from its starting point (see the module documentation for the method).
/// With [`Options::interrupt`] every evaluation polls the flag too
/// ([`super::interrupt`]): a raised flag ends the solve with status `Interrupted` at the last
/// accepted point, within one evaluation or one interior-point iteration of a QP.
pub fn solve(nlp: &dyn Nlp, options: &Options) -> Solution {
    let Some(flag) = &options.interrupt else {
        return solve_unguarded(nlp, options);
    };
    let interrupt = Interrupt::from(Arc::clone(flag));
    let mut solution = solve_unguarded(&Interruptible::new(nlp, &interrupt), options);
    if interrupt.is_raised() && solution.status == Status::EvaluationError {
        solution.status = Status::Interrupted;
    }
    solution
}

fn solve_unguarded(nlp: &dyn Nlp, options: &Options) -> Solution {
    let started = Instant::now();
    let ev = Evaluator::new(nlp);
    let n = ev.dims.n;
    let quasi_newton = if n <= options.tuning.dense_bfgs_limit {
        HessianMode::Bfgs
    } else {
        HessianMode::Lbfgs
    };
    let mode = match options.hessian {
        HessianMode::Auto | HessianMode::Exact if ev.dims.hess_nnz > 0 => HessianMode::Exact,
        HessianMode::Auto | HessianMode::Exact => quasi_newton,
        // No n×n matrix above the dense QP's size limit: L-BFGS instead of dense BFGS.
        HessianMode::Bfgs if n > qp::DENSE_LIMIT => HessianMode::Lbfgs,
        other => other,
    };
    let model = match mode {
        HessianMode::Lbfgs => Model::Lbfgs(Lbfgs::new(n, options.lbfgs_memory)),
        HessianMode::Exact => Model::Exact {
            shift: if options.progress_window == 0 {
                InertiaShift::converging()
            } else {
                InertiaShift::default()
            },
            dense: None,
            sparse: None,
            row_weights: Vec::new(),
            inertia: 0.0,
        },
        _ => Model::Bfgs(DenseBfgs::new(n)),
    };
    let qp_method = match options.qp_method {
        QpMethod::Auto if mode == HessianMode::Exact && n > options.tuning.exact_sparse_limit => {
            QpMethod::Sparse
        }
        other => other,
    };
    let m = ev.dims.m;
    let jac_pattern = Jacobian::new(m, n, &ev.jac_rows, &ev.jac_cols);
    // Every QP polls the flag too: a long factorization sequence stops within one iteration.
    let interrupt = (options.interrupt.clone()).map_or_else(Interrupt::new, Interrupt::from);
    let warm = || WarmStart::new(qp_method).interruptible(interrupt.clone());
    let mut sqp = Sqp {
        lambda: vec![0.0; ev.dims.m],
        last_qp_multipliers: 0.0,
        ev,
        options,
        tuning: &options.tuning,
        started,
        log: Vec::new(),
        live: RefCell::new(log::LiveLog::on(&options.log, options.verbosity)),
        model,
        rho: vec![0.0; m],
        warm: warm(),
        elastic_warm: warm(),
        feasibility_warm: RefCell::new(warm()),
        qp_method,
        jac_pattern,
        radius: f64::INFINITY,
        active_signature: Vec::new(),
        active_stable: 0,
        newton_base: None,
        endgame: false,
        endgame_refused: false,
        hessian_due: false,
    };
    sqp.run()
}

impl Sqp<'_> {
    /// Whether QPs go to the sparse method (no n×n matrices).
    pub(super) fn sparse_qp(&self) -> bool {
        self.qp_method.is_sparse(self.ev.dims.n)
    }

    pub(super) fn elapsed(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    pub(super) fn say(&self, text: &str) {
        self.live.borrow_mut().message(text);
    }

    /// The constraint Jacobian in CSR form from its values in the evaluator's order.
    pub(super) fn jacobian(&self, values: &[f64]) -> CsrMatrix<f64> {
        self.jac_pattern.csr(values)
    }

    pub(super) fn merit(&self, v: &Values) -> f64 {
        v.f + merit::weighted_violation(&v.c, &self.ev.cl, &self.ev.cu, &self.rho)
    }

    /// The major iterations (see the module documentation): one method per phase, every
    /// decision a [`Next`].
    fn run(&mut self) -> Solution {
        let mut state = match self.begin() {
            ControlFlow::Continue(state) => state,
            ControlFlow::Break(solution) => return solution,
        };
        loop {
            let jac = self.jacobian(&state.point.derivatives.jac);
            let arrival = state.arrival_multipliers.take();
            if let Some(lambda) = &arrival {
                let (kkt, _) = self.kkt(&state.point, &jac, lambda);
                if self.converged(kkt) {
                    self.record(&state, kkt);
                    return self.finish(Status::Optimal, &state.point, Some(lambda));
                }
            }
            if std::mem::take(&mut self.hessian_due)
                && let Err(e) = self.update_exact(&state.point)
            {
                let status = self.eval_status(&e);
                return self.finish(status, &state.point, arrival.as_deref());
            }
            let step = self.choose_step(&state.point, &jac);
            self.watch_exact_weights(&mut state);
            let (kkt, _) = self.kkt(&state.point, &jac, &step.qp.lambda);
            self.record(&state, kkt);
            match self.decide(&mut state, &step, kkt, &jac) {
                Next::Accept(alpha) => {
                    state.advance(alpha, step.qp_iterations);
                    state.arrival_multipliers = Some(step.qp.lambda);
                }
                Next::Retry => state.advance(0.0, step.qp_iterations),
                Next::Finish(status) => {
                    return self.finish(status, &state.point, Some(&step.qp.lambda));
                }
            }
        }
    }

    /// One iteration after its QP phase: termination tests, then either a retry of a failed
    /// QP or the penalty phase and a globalized step, and what its outcome means.
    fn decide(
        &mut self,
        state: &mut State,
        step: &StepChoice,
        kkt: Kkt,
        jac: &CsrMatrix<f64>,
    ) -> Next {
        if let Some(next) = self.termination(state, step, kkt, jac) {
            return next;
        }
        if step.qp.status != QpStatus::Optimal {
            return self.failed_qp(state, step, kkt, jac);
        }
        let descent = self.penalty(&state.point, jac, step);
        let d = &step.qp.d;
        let outcome = match self.options.globalization {
            Globalization::LineSearch => {
                self.line_search(&state.point, jac, d, descent.slope, descent.violation_slope)
            }
            Globalization::TrustRegion => {
                self.trust_region_step(&state.point, jac, d, descent.slope, descent.dhd)
            }
        };
        if self.newton_base.is_some()
            && matches!(outcome, LineSearch::Rejected | LineSearch::Failed)
        {
            // The iteration is repeated with the convexified QP's step.
            self.endgame = false;
            self.endgame_refused = true;
            return Next::Retry;
        }
        match outcome {
            LineSearch::Rejected => Next::Retry,
            LineSearch::Accepted { point, alpha } => {
                self.accept(state, step, jac, &descent, point, alpha)
            }
            LineSearch::Fatal => Next::Finish(Status::EvaluationError),
            LineSearch::Failed => self.recover(state, kkt, jac),
        }
    }

    /// Moves to the accepted point: exact-step damping, the QP multipliers, the Hessian
    /// update, the least violated iterate.
    fn accept(
        &mut self,
        state: &mut State,
        step: &StepChoice,
        jac: &CsrMatrix<f64>,
        descent: &Descent,
        next: state::Point,
        alpha: f64,
    ) -> Next {
        let d = &step.qp.d;
        state.model_reset = false;
        self.endgame = self.newton_base.is_some() && alpha == 1.0;
        self.endgame_refused = false;
        if !self.model.is_quasi_newton()
            && !step.elastic
            && self.options.globalization == Globalization::LineSearch
        {
            let dhd = descent.dhd - self.model.augmentation_curvature(jac, d);
            self.damp_exact_steps(alpha, dhd, d);
        }
        let qp_size = largest(&step.qp.lambda);
        let jumped = qp_size > MULTIPLIER_JUMP * self.last_qp_multipliers.max(1.0);
        self.last_qp_multipliers = qp_size;
        if self.model.is_quasi_newton() || !jumped {
            self.lambda = step.qp.lambda.clone();
        }
        let updated = self.update_model(&state.point, &next);
        state.point = next;
        if let Err(e) = updated {
            return Next::Finish(self.eval_status(&e));
        }
        if self.violation(&state.point) < self.violation(&state.least_violated) {
            state.least_violated = state.point.clone();
        }
        Next::Accept(alpha)
    }

    /// After a failed line search or trust-region step: the quasi-Newton model instead of the
    /// exact Hessian, or a fresh quasi-Newton model; when that was tried already, the solve
    /// ends `Acceptable` within 100× the tolerances, else stalled or infeasible (after a
    /// retreat, if one is left).
    fn recover(&mut self, state: &mut State, kkt: Kkt, jac: &CsrMatrix<f64>) -> Next {
        if !self.model.is_quasi_newton() {
            self.abandon_exact_hessian("the line search failed");
            state.model_reset = true;
            return Next::Retry;
        }
        if !state.model_reset {
            // A poor quasi-Newton model is the usual cause: start it afresh.
            self.model.reset();
            state.model_reset = true;
            return Next::Retry;
        }
        let (tol, ctol) = (self.options.tolerance, self.options.constraint_tolerance);
        let status = if kkt.primal <= 100.0 * ctol && kkt.optimality <= 100.0 * tol {
            Status::Acceptable
        } else {
            self.stalled_status(kkt, &state.point, jac)
        };
        if status == Status::Infeasible && self.retreat(state) {
            return Next::Retry;
        }
        Next::Finish(status)
    }
}

/// Largest jump of the QP multipliers (max-norm, against max(1, ‖λ‖∞) of the previous QP's, or
/// for the first QP of the initial least-squares estimate) that the exact Hessian follows at
/// once. Such multipliers come from a nearly inconsistent linearization (truss balance rows of a
/// joint whose members all went idle reached 1e11 and fell back at the next step): weighting the
/// constraint curvature by them makes the next Hessian need a shift of 1e7–1e13, and the steps
/// freeze. The exact Hessian then keeps its multipliers for that iteration; a jump the next QP
/// confirms is followed one iteration late. Against 1 instead of the estimate, every solve whose
/// multipliers are naturally above 1e3 refused its first QP's (through_deck_cantilever's rounds
/// then took other paths: 5,442 iterations to IterationLimit instead of 1,317 to Optimal). The
/// step, the merit weights and the termination tests use the QP's multipliers in any case, and
/// so do quasi-Newton updates (their Lagrangian gradient differences need the multipliers of the
/// step).
const MULTIPLIER_JUMP: f64 = 1e3;

/// ‖v‖∞.
pub(super) fn largest(v: &[f64]) -> f64 {
    v.iter().fold(0.0_f64, |a, b| a.max(b.abs()))
}
