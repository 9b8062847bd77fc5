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
//!    f < −1e20 or ‖x‖∞ > 1e10 ends the solve `Unbounded`.
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
//!
//! Hessian choice in `HessianMode::Auto`: the exact Hessian when the problem has one; else
//! dense BFGS for n ≤ [`Tuning::dense_bfgs_limit`] (an n×n update costs O(n²) per iteration and the
//! dense QP O(n³) anyway), L-BFGS above. `HessianMode::Exact` on a problem without a Hessian
//! makes the same quasi-Newton choice. `HessianMode::Bfgs` above [`qp::DENSE_LIMIT`] variables
//! is served by L-BFGS (no n×n matrix on the large-problem path).
//!
//! QP method ([`Options::qp_method`], see `qp::select`): the dense active-set method up to
//! [`qp::DENSE_LIMIT`] variables (up to [`Tuning::exact_sparse_limit`] with the exact Hessian), the
//! sparse interior-point method above, with the exact
//! Hessian kept as a sparse lower triangle (convexified inside the QP) and L-BFGS in compact
//! form; elastic and least-violation subproblems use the same method.

use std::cell::RefCell;
use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use nalgebra_sparse::{CooMatrix, CsrMatrix};

use super::elastic::{self, Linearization};
use super::evaluator::{Derivatives, Evaluator, Values};
use super::hessian::{self, DenseBfgs, InertiaShift, Lbfgs, Model};
use super::log;
use super::merit;
use super::multipliers::{self, LinearizedPoint};
use super::noise;
use super::qp::{self, QpHessian, QpMethod, QpProblem, QpSolution, QpStatus, WarmStart};
use super::termination::{self, Kkt, KktInput};
use super::{
    EvalError, Globalization, HessianMode, Interrupt, Interruptible, IterationRecord, Nlp, Options,
    Solution, Status, Tuning,
};

/// Consecutive iterations within 100× the tolerances (`Acceptable` level), in windows of
/// `Tuning::acceptable_iterations`: a window that does not improve the best KKT ratio
/// `max(primal/ctol, optimality/tol)` before it by the factor `Tuning::acceptable_progress` ends
/// the solve (IPOPT's acceptable test, which ends after a fixed count, would stop an L-BFGS solve
/// that converges linearly: the 100-link chain on the sparse path went from 2e-5 to 1e-6 in
/// 45 such iterations).
#[derive(Default)]
struct AcceptableRun {
    /// Iterations in the current window (0: not at the acceptable level).
    length: usize,
    /// Best ratio before the current window.
    before: f64,
    /// Best ratio within the current window.
    within: f64,
}

impl AcceptableRun {
    /// Records the KKT ratio of an iteration; true when progress has stopped at the
    /// acceptable level.
    fn stalled(&mut self, ratio: f64, tuning: &Tuning) -> bool {
        if ratio > 100.0 {
            *self = AcceptableRun::default();
            return false;
        }
        if self.length == 0 {
            // The run's first iteration is the reference of its first window.
            self.before = ratio;
            self.within = f64::INFINITY;
            self.length = 1;
            return false;
        }
        self.length += 1;
        self.within = self.within.min(ratio);
        if self.length < tuning.acceptable_iterations {
            return false;
        }
        if self.within > tuning.acceptable_progress * self.before {
            return true;
        }
        // Progress: judge the next window against the best ratio so far.
        self.before = self.within;
        self.within = f64::INFINITY;
        self.length = 1;
        false
    }
}

/// One accepted point with everything evaluated there.
#[derive(Clone)]
struct Point {
    x: Vec<f64>,
    values: Values,
    derivatives: Derivatives,
}

/// What the QP phase of an iteration produced.
struct StepChoice {
    qp: QpSolution,
    /// Whether the step came from the elastic subproblem.
    elastic: bool,
    /// x is a stationary point of the violation while infeasible.
    infeasible_stationary: bool,
    qp_iterations: usize,
}

/// The sufficient-decrease tests of one line search.
struct Acceptance {
    /// Merit value at the current point.
    phi0: f64,
    /// Upper bound of the merit function's directional derivative along d.
    slope: f64,
    /// ℓ1 violation at the current point.
    v0: f64,
    /// Predicted violation change along d when the violation must decrease in fact.
    violation_slope: Option<f64>,
    /// Largest ℓ1 violation accepted at a trial point (see [`Tuning::violation_growth`]).
    violation_cap: f64,
    /// Change of φ that counts as no change: its rounding level.
    merit_noise: f64,
    /// Change of the violation that counts as no change.
    violation_noise: f64,
    /// Whether the noise of φ and of the violation has been measured along d.
    noise_measured: bool,
}

enum LineSearch {
    Accepted {
        point: Point,
        alpha: f64,
    },
    /// Trust region only: the step was rejected and the radius reduced; the iteration is
    /// repeated at the same point.
    Rejected,
    Failed,
    Fatal,
}

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
    warm: WarmStart,
    elastic_warm: WarmStart,
    /// For the least-violation subproblems (their own shape, so their own sparse analysis).
    feasibility_warm: RefCell<WarmStart>,
    jac_shape: (Vec<usize>, Vec<usize>),
    /// The QP method in effect ([`Options::qp_method`], with `Auto` resolved for exact
    /// Hessians above [`Tuning::exact_sparse_limit`]).
    qp_method: QpMethod,
    /// ℓ∞ trust-region radius on the step (unscaled variables; infinite under the line search,
    /// and at most [`Tuning::step_limit`]·(1 + ‖x‖∞) in effect).
    radius: f64,
}

/// Solves `nlp` from its starting point (see the module documentation for the method).
/// With [`Options::interrupt`] every evaluation polls the flag too
/// ([`super::interrupt`]): a raised flag ends the solve with status `Interrupted` at the last
/// accepted point, within one evaluation.
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
            shift: InertiaShift::default(),
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
    let jac_shape = (ev.jac_rows.clone(), ev.jac_cols.clone());
    let m = ev.dims.m;
    let mut sqp = Sqp {
        lambda: vec![0.0; ev.dims.m],
        ev,
        options,
        tuning: &options.tuning,
        started,
        log: Vec::new(),
        live: RefCell::new(log::LiveLog::on(&options.log, options.verbosity)),
        model,
        rho: vec![0.0; m],
        warm: WarmStart::new(qp_method),
        elastic_warm: WarmStart::new(qp_method),
        feasibility_warm: RefCell::new(WarmStart::new(qp_method)),
        qp_method,
        jac_shape,
        radius: f64::INFINITY,
    };
    sqp.run()
}

impl<'a> Sqp<'a> {
    /// A subproblem's multipliers in the problem's terms: the exact model's row weights
    /// undone, and void rows' multipliers set to 0 (`multipliers::clear_void_rows`).
    fn subproblem_multipliers(&self, lambda: &mut [f64], jac: &CsrMatrix<f64>, d: &[f64]) {
        self.model.restore_multipliers(lambda, jac, d);
        multipliers::clear_void_rows(jac, lambda);
    }

    /// Relative tolerance handed to the QP method (the sparse one stops at it; two orders
    /// tighter than the outer test so that QP multipliers do not limit the final accuracy).
    fn qp_tolerance(&self) -> f64 {
        (0.01 * self.options.tolerance).clamp(1e-12, 1e-8)
    }

    /// Whether QPs go to the sparse method (no n×n matrices).
    fn sparse_qp(&self) -> bool {
        self.qp_method.is_sparse(self.ev.dims.n)
    }

    fn elapsed(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    fn say(&self, text: &str) {
        self.live.borrow_mut().message(text);
    }

    /// The size line before the column header (see `log::size_line`).
    fn say_size(&self) {
        let hessian = match &self.model {
            Model::Bfgs(_) => "dense BFGS",
            Model::Lbfgs(_) => "L-BFGS",
            Model::Exact { .. } => "exact",
        };
        let qp = if self.sparse_qp() {
            "sparse interior point"
        } else {
            "dense active set"
        };
        let stage = &self.options.log.stage;
        let prefix = if stage.is_empty() {
            String::new()
        } else {
            format!("{stage}: ")
        };
        self.say(&format!(
            "{prefix}{}",
            log::size_line(&self.ev.dims, hessian, qp)
        ));
    }

    fn jacobian(&self, values: &[f64]) -> CsrMatrix<f64> {
        let (m, n) = (self.ev.dims.m, self.ev.dims.n);
        let mut coo = CooMatrix::new(m, n);
        for ((&r, &c), &v) in self.jac_shape.0.iter().zip(&self.jac_shape.1).zip(values) {
            coo.push(r, c, v);
        }
        CsrMatrix::from(&coo)
    }

    fn merit(&self, v: &Values) -> f64 {
        v.f + merit::weighted_violation(&v.c, &self.ev.cl, &self.ev.cu, &self.rho)
    }

    /// The start: clamp into the bounds, choose scales, evaluate.
    fn initial_point(&mut self) -> Result<Point, (Status, Vec<f64>)> {
        let mut x = self.ev.start();
        for ((x, &l), &u) in x.iter_mut().zip(&self.ev.xl).zip(&self.ev.xu) {
            *x = x.clamp(l, u);
        }
        let raw = self
            .ev
            .raw_derivatives(&x)
            .map_err(|_| (Status::EvaluationError, x.clone()))?;
        self.ev.set_scaling(&raw.grad, &raw.jac);
        let values = self
            .ev
            .values(&x)
            .map_err(|_| (Status::EvaluationError, x.clone()))?;
        let derivatives = self
            .ev
            .derivatives(&x)
            .map_err(|_| (Status::EvaluationError, x.clone()))?;
        Ok(Point {
            x,
            values,
            derivatives,
        })
    }

    fn run(&mut self) -> Solution {
        if let Err(msg) = self.ev.check_input() {
            self.say(&format!("invalid problem: {msg}"));
            let x = self.ev.start();
            return self.failed_start(Status::EvaluationError, x);
        }
        let mut point = match self.initial_point() {
            Ok(p) => p,
            Err((status, x)) => return self.failed_start(status, x),
        };
        if self.options.verbosity >= 1 {
            self.say_size();
            self.live.borrow_mut().header();
        }
        if !self.model.is_quasi_newton() {
            self.lambda = multipliers::least_squares(&LinearizedPoint {
                grad: &point.derivatives.grad,
                jac_rows: &self.jac_shape.0,
                jac_cols: &self.jac_shape.1,
                jac: &point.derivatives.jac,
                c: &point.values.c,
                cl: &self.ev.cl,
                cu: &self.ev.cu,
            });
        }
        if let Err(e) = self.update_exact(&point) {
            let status = self.eval_status(&e);
            return self.finish(status, &point, None);
        }
        let mut alpha_in = 0.0;
        let mut qp_in = 0;
        let mut acceptable = AcceptableRun::default();
        let mut reset_done = false;
        let mut retreats_left = self.tuning.max_retreats;
        let mut heavy_weights = 0;
        let mut least_violated = point.clone();
        let mut iteration = 0;
        loop {
            let jac = self.jacobian(&point.derivatives.jac);
            let step = self.choose_step(&point, &jac);
            if !self.model.is_quasi_newton()
                && self.rho.iter().any(|&w| w > self.tuning.exact_weight_limit)
            {
                heavy_weights += 1;
                if heavy_weights >= self.tuning.exact_patience {
                    self.abandon_exact_hessian("the penalty weights stayed huge");
                }
            } else {
                heavy_weights = 0;
            }
            let lambda_qp = step.qp.lambda.clone();
            let (kkt, _) = self.kkt(&point, &jac, &lambda_qp);
            self.record(iteration, &point, kkt, alpha_in, qp_in);

            let tol = self.options.tolerance;
            let ctol = self.options.constraint_tolerance;
            if kkt.primal <= ctol && kkt.optimality <= tol {
                return self.finish(Status::Optimal, &point, Some(&lambda_qp));
            }
            let infeasible = step.infeasible_stationary
                || (step.qp.status != QpStatus::Optimal
                    && self.stalled_status(kkt, &point, &jac) == Status::Infeasible);
            if infeasible {
                if self.retreat(&mut point, &least_violated, &mut retreats_left) {
                    alpha_in = 0.0;
                    qp_in = step.qp_iterations;
                    iteration += 1;
                    continue;
                }
                return self.finish(Status::Infeasible, &point, Some(&lambda_qp));
            }
            let xnorm = point.x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            if kkt.primal <= 100.0 * ctol
                && (point.values.f / self.ev.scale_f < self.tuning.unbounded_objective
                    || xnorm > self.tuning.unbounded_step)
            {
                return self.finish(Status::Unbounded, &point, Some(&lambda_qp));
            }
            if acceptable.stalled((kkt.primal / ctol).max(kkt.optimality / tol), self.tuning) {
                return self.finish(Status::Acceptable, &point, Some(&lambda_qp));
            }
            if let Some(status) = self.limit_reached(iteration) {
                return self.finish(status, &point, Some(&lambda_qp));
            }
            if step.qp.status != QpStatus::Optimal {
                if self.options.verbosity >= 2 {
                    self.say(&format!(
                        "      QP ended {:?} (elastic: {})",
                        step.qp.status, step.elastic
                    ));
                }
                // Under the trust region: a fresh quasi-Newton model (an ill-conditioned one
                // fails the dense QP's factorization), then smaller radii.
                let radius = self.effective_radius(&point);
                if radius.is_finite() && radius > self.tuning.qp_retry_radius * (1.0 + xnorm) {
                    if self.model.is_quasi_newton() && !reset_done {
                        self.model.reset();
                        reset_done = true;
                    } else {
                        self.radius = 0.1 * radius;
                    }
                    alpha_in = 0.0;
                    qp_in = step.qp_iterations;
                    iteration += 1;
                    continue;
                }
                let status = self.stalled_status(kkt, &point, &jac);
                return self.finish(status, &point, Some(&lambda_qp));
            }

            // Penalty weights so that d descends on the merit function.
            let d = &step.qp.d;
            if !step.elastic {
                merit::powell_update(&mut self.rho, &lambda_qp);
            }
            let gd: f64 = point
                .derivatives
                .grad
                .iter()
                .zip(d)
                .map(|(a, b)| a * b)
                .sum();
            // The curvature the QP used: a sparse exact Hessian is convexified inside the QP.
            let shift = if step.elastic {
                self.elastic_warm.convexification()
            } else {
                self.warm.convexification()
            };
            let dhd: f64 = self
                .model
                .times(d)
                .iter()
                .zip(d)
                .map(|(a, b)| a * b)
                .sum::<f64>()
                + shift.curvature(d);
            // Byrd–Nocedal safeguard: the weighted linearized violation decrease must pay for
            // a tenth more than the model's objective change, or the weights of the rows that
            // decrease are raised uniformly (Powell's rule decays the excess later).
            let rows = self.row_reductions(&point, &jac, d);
            let needed = gd + 0.5 * dhd.max(0.0);
            let have: f64 = 0.9 * rows.iter().zip(&self.rho).map(|(r, w)| r * w).sum::<f64>();
            let positive: f64 = rows.iter().filter(|&&r| r > 0.0).sum();
            if positive > 0.0 && needed > have {
                let tau = (needed - have) / (0.9 * positive);
                for (w, r) in self.rho.iter_mut().zip(&rows) {
                    if *r > 0.0 {
                        *w += tau;
                    }
                }
            }
            let reduction: f64 = rows.iter().zip(&self.rho).map(|(r, w)| r * w).sum();
            let slope = gd - reduction;
            if self.options.verbosity >= 2 {
                self.say(&format!(
                    "      |d| = {:.3e}  g'd = {gd:.3e}  d'Hd = {dhd:.3e}  lin.red = {reduction:.3e}  max rho = {:.3e}  slope = {slope:.3e}  shift = {:.2e}  flipped = {}  qp = {:?}",
                    d.iter().fold(0.0_f64, |a, v| a.max(v.abs())),
                    self.rho.iter().fold(0.0_f64, |a, v| a.max(*v)),
                    shift.shift,
                    shift.flip.iter().filter(|&&f| f > 0.0).count(),
                    step.qp.status
                ));
            }

            // A step whose predicted merit decrease comes mostly from the violation (and every
            // elastic step) must reduce the violation in fact: otherwise a step into a region
            // where the linearization is poor can pass the Armijo test on the objective alone.
            let predicted: f64 = rows.iter().sum();
            let violation_slope = (predicted > 0.0 && (step.elastic || reduction >= -0.5 * slope))
                .then_some(-predicted);
            let outcome = match self.options.globalization {
                Globalization::LineSearch => {
                    self.line_search(&point, &jac, d, slope, violation_slope)
                }
                Globalization::TrustRegion => self.trust_region_step(&point, &jac, d, slope, dhd),
            };
            match outcome {
                LineSearch::Rejected => {
                    alpha_in = 0.0;
                    qp_in = step.qp_iterations;
                }
                LineSearch::Accepted { point: next, alpha } => {
                    reset_done = false;
                    if !self.model.is_quasi_newton()
                        && !step.elastic
                        && self.options.globalization == Globalization::LineSearch
                    {
                        let dhd = dhd - self.model.augmentation_curvature(&jac, d);
                        self.damp_exact_steps(alpha, dhd, d);
                    }
                    self.lambda = lambda_qp;
                    if let Err(e) = self.update_model(&point, &next) {
                        let status = self.eval_status(&e);
                        return self.finish(status, &next, Some(&self.lambda.clone()));
                    }
                    point = next;
                    if self.violation(&point) < self.violation(&least_violated) {
                        least_violated = point.clone();
                    }
                    alpha_in = alpha;
                    qp_in = step.qp_iterations;
                }
                LineSearch::Fatal => {
                    return self.finish(Status::EvaluationError, &point, Some(&lambda_qp));
                }
                LineSearch::Failed => {
                    if !self.model.is_quasi_newton() {
                        self.abandon_exact_hessian("the line search failed");
                        reset_done = true;
                        alpha_in = 0.0;
                        qp_in = step.qp_iterations;
                    } else if !reset_done {
                        // A poor quasi-Newton model is the usual cause: start it afresh.
                        self.model.reset();
                        reset_done = true;
                        alpha_in = 0.0;
                        qp_in = step.qp_iterations;
                    } else {
                        let status = if kkt.primal <= 100.0 * ctol && kkt.optimality <= 100.0 * tol
                        {
                            Status::Acceptable
                        } else {
                            self.stalled_status(kkt, &point, &jac)
                        };
                        if status == Status::Infeasible
                            && self.retreat(&mut point, &least_violated, &mut retreats_left)
                        {
                            alpha_in = 0.0;
                            qp_in = step.qp_iterations;
                            iteration += 1;
                            continue;
                        }
                        return self.finish(status, &point, Some(&lambda_qp));
                    }
                }
            }
            iteration += 1;
        }
    }

    /// Shift floor of the next sparse QPs with the exact Hessian, from the step length α the
    /// line search accepted: a Newton step that had to be cut to α < 1 is dominated by
    /// directions of small curvature μ (the Rayleigh quotient `dᵀ(H + δI)d / dᵀd`) along which
    /// the functions are far from quadratic (tangential sliding of a mesh: the linearized
    /// constraints hold, the true ones change at second order). The shift δ = μ(1/α − 1) would
    /// have made the step along such a direction the accepted one, while directions of large
    /// curvature keep their full Newton step, instead of all being cut to α. After a full step
    /// the floor decays ×1/[`Tuning::damping_decay`] (to 0 below `Tuning::damping_min` of the
    /// Hessian scale), like a trust region that grows back.
    ///
    /// Only a severe cut (α ≤ [`Tuning::damping_cut`]) raises it, and μ leaves out the inertia
    /// correction above the floor (it damps the steps already): a floor ratcheting up on every
    /// cut step by μ including that correction slowed the 250-link hanging chain (shift ~3e4)
    /// from 30 to 345 iterations.
    fn damp_exact_steps(&mut self, alpha: f64, dhd: f64, d: &[f64]) {
        let dd: f64 = d.iter().map(|v| v * v).sum();
        // The curvature along d without the inertia correction above the floor.
        let correction = match &self.model {
            Model::Exact {
                dense: Some(_),
                inertia,
                ..
            } => inertia * dd,
            _ => (self.warm.convexification().curvature(d) - self.warm.shift_floor() * dd).max(0.0),
        };
        let curvature = dhd - correction;
        let floor = if alpha <= self.tuning.damping_cut && dd > 0.0 && curvature > 0.0 {
            self.warm
                .shift_floor()
                .max(curvature / dd * (1.0 / alpha - 1.0))
        } else {
            self.warm.shift_floor() / self.tuning.damping_decay
        };
        let floor = if floor < self.tuning.damping_min {
            0.0
        } else {
            floor
        };
        self.warm.set_shift_floor(floor);
    }

    /// Before `Infeasible` is declared at a stationary point of the violation that is clearly
    /// worse than an earlier iterate (reached by a long step into a region where the
    /// linearization misled), goes back to the least violated iterate with a stiffer
    /// quasi-Newton model (shorter steps) and heavier penalty weights. Returns whether it did.
    fn retreat(&mut self, point: &mut Point, least: &Point, left: &mut usize) -> bool {
        if *left == 0 || self.violation(least) >= 0.9 * self.violation(point) {
            return false;
        }
        *left -= 1;
        *point = least.clone();
        self.model.reset_stiffer(self.tuning.retreat_stiffness);
        for w in &mut self.rho {
            *w = (*w * self.tuning.retreat_stiffness).max(1.0);
        }
        self.warm.clear();
        if let Err(e) = self.update_exact(point) {
            self.say(&format!("exact Hessian failed after a retreat: {e}"));
        }
        true
    }

    /// Switches from the exact Hessian to the quasi-Newton model of `HessianMode::Auto` (dense
    /// BFGS or L-BFGS) when it cannot make progress: its curvature, scaled by diverging
    /// multipliers far from a solution, can freeze the steps, while a quasi-Newton model stays
    /// bounded. The penalty weights restart from the current multipliers.
    fn abandon_exact_hessian(&mut self, why: &str) {
        let n = self.ev.dims.n;
        self.model = if n <= self.tuning.dense_bfgs_limit {
            Model::Bfgs(DenseBfgs::new(n))
        } else {
            Model::Lbfgs(Lbfgs::new(n, self.options.lbfgs_memory))
        };
        for (w, l) in self.rho.iter_mut().zip(&self.lambda) {
            *w = l.abs().min(self.tuning.elastic_weight);
        }
        self.say(&format!(
            "      exact Hessian abandoned ({why}); continuing with quasi-Newton updates"
        ));
    }

    /// Unweighted ℓ1 violation of the scaled constraints at a point.
    fn violation(&self, p: &Point) -> f64 {
        merit::l1_violation(&p.values.c, &self.ev.cl, &self.ev.cu)
    }

    /// Stalled, unless x is infeasible and stationary for the violation (then Infeasible).
    fn stalled_status(&self, kkt: Kkt, point: &Point, jac: &CsrMatrix<f64>) -> Status {
        if kkt.primal > self.options.constraint_tolerance && self.violation_stationary(point, jac).0
        {
            Status::Infeasible
        } else {
            Status::Stalled
        }
    }

    fn limit_reached(&self, iteration: usize) -> Option<Status> {
        if let Some(flag) = &self.options.interrupt
            && flag.load(Ordering::Relaxed)
        {
            return Some(Status::Interrupted);
        }
        if let Some(limit) = self.options.max_time
            && self.elapsed() >= limit
        {
            return Some(Status::TimeLimit);
        }
        (iteration >= self.options.max_iterations).then_some(Status::IterationLimit)
    }

    fn eval_status(&self, e: &EvalError) -> Status {
        match e {
            EvalError::Fatal(_) | EvalError::Domain(_) => Status::EvaluationError,
        }
    }

    /// The QP's step bounds: the variable bounds, and under the trust region the radius.
    fn step_box(&self, point: &Point) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let (mut dl, mut du, bl, bu) = self.bounds_of_step(point);
        let radius = self.effective_radius(point);
        if radius.is_finite() {
            for (l, u) in dl.iter_mut().zip(du.iter_mut()) {
                *l = l.max(-radius);
                *u = u.min(radius);
            }
        }
        (dl, du, bl, bu)
    }

    /// The trust-region radius in effect at `point` (infinite under the line search).
    fn effective_radius(&self, point: &Point) -> f64 {
        if self.options.globalization == Globalization::LineSearch {
            return f64::INFINITY;
        }
        let xnorm = point.x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        self.radius.min(self.tuning.step_limit * (1.0 + xnorm))
    }

    fn bounds_of_step(&self, point: &Point) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let x = &point.x;
        let c = &point.values.c;
        let dl = x.iter().zip(&self.ev.xl).map(|(x, l)| l - x).collect();
        let du = x.iter().zip(&self.ev.xu).map(|(x, u)| u - x).collect();
        let bl = c.iter().zip(&self.ev.cl).map(|(c, l)| l - c).collect();
        let bu = c.iter().zip(&self.ev.cu).map(|(c, u)| u - c).collect();
        (dl, du, bl, bu)
    }

    /// Whether x is a stationary point of the ℓ1 violation: the least linearized violation
    /// within a box of radius Δ = max(1, ‖x‖∞) improves on the current one v by no more than
    /// `tolerance·v` (invariant under scaling of c; near a stationary point the reduction
    /// vanishes to first order). Also returns the least linearized violation.
    fn violation_stationary(&self, point: &Point, jac: &CsrMatrix<f64>) -> (bool, f64) {
        let (now, least) = self.least_violation(point, jac, Self::stationarity_radius(point));
        match least {
            Some(least) => (now - least <= self.options.tolerance * now, least),
            None => (false, now),
        }
    }

    /// Radius of the box in which [`Self::violation_stationary`] looks for a lower violation:
    /// max(1, ‖x‖∞).
    fn stationarity_radius(point: &Point) -> f64 {
        point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()))
    }

    /// The current linearized ℓ1 violation and the least one reachable within `|d|∞ ≤
    /// radius` and the variable bounds (None if that subproblem fails).
    fn least_violation(
        &self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        radius: f64,
    ) -> (f64, Option<f64>) {
        let (dl, du, bl, bu) = self.bounds_of_step(point);
        let lin = Linearization {
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        let now = lin.violation_now();
        let mut warm = self.feasibility_warm.borrow_mut();
        let least = elastic::least_violation(&lin, radius, &mut warm, self.qp_tolerance())
            .map(|(least, _)| least);
        (now, least)
    }

    /// Solves the QP at `point`, switching to elastic mode when it is inconsistent.
    fn choose_step(&mut self, point: &Point, jac: &CsrMatrix<f64>) -> StepChoice {
        let (dl, du, bl, bu) = self.step_box(point);
        let g = &point.derivatives.grad;
        let tol = self.qp_tolerance();
        let problem = QpProblem {
            h: self.model.qp_hessian(),
            g,
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        let mut qp = qp::solve(&problem, &mut self.warm, tol);
        self.subproblem_multipliers(&mut qp.lambda, jac, &qp.d);
        let lin = Linearization {
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        let now = lin.violation_now();
        // Size of the constraint forces λᵢ∇cᵢ against the objective's gradient.
        let mut force = 0.0_f64;
        for (i, row) in jac.row_iter().enumerate() {
            let norm = row.values().iter().fold(0.0_f64, |a, v| a.max(v.abs()));
            force = force.max(qp.lambda[i].abs() * norm);
        }
        let gmax = g.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
        if qp.status == QpStatus::Optimal && force <= self.tuning.elastic_weight * gmax {
            let iterations = qp.iterations;
            return StepChoice {
                qp,
                elastic: false,
                infeasible_stationary: false,
                qp_iterations: iterations,
            };
        }
        // Elastic mode.
        let mut iterations = qp.iterations;
        let (stationary, least) = self.violation_stationary(point, jac);
        let primal_bad = {
            let (kkt, _) = self.kkt(point, jac, &vec![0.0; self.ev.dims.m]);
            kkt.primal > self.options.constraint_tolerance
        };
        let dense = (!self.sparse_qp()).then(|| self.model.dense(self.ev.dims.n));
        let h = dense
            .as_ref()
            .map_or_else(|| self.model.qp_hessian(), QpHessian::Dense);
        let floor = self
            .rho
            .iter()
            .chain(self.lambda.iter())
            .fold(1.0_f64, |a, v| a.max(v.abs()))
            .min(self.tuning.elastic_weight);
        let mut rho: Vec<f64> = self
            .rho
            .iter()
            .map(|w| w.clamp(floor, self.tuning.elastic_weight.max(floor)))
            .collect();
        // Steering asks for a tenth of what the linearization can reach: within the trust
        // region, if it is tighter than the stationarity test's box.
        let radius = self.effective_radius(point);
        let least = if radius < Self::stationarity_radius(point) {
            self.least_violation(point, jac, radius).1.unwrap_or(least)
        } else {
            least
        };
        let best_reduction = (now - least).max(0.0);
        let mut sol = elastic::solve_elastic(h, g, &lin, &rho, &mut self.elastic_warm, tol);
        self.subproblem_multipliers(&mut sol.lambda, jac, &sol.d);
        iterations += sol.iterations;
        for _ in 0..self.tuning.max_steering {
            let after = lin.violation_after(&sol.d);
            let enough = after <= 1e-12 * (1.0 + now) || now - after >= 0.1 * best_reduction;
            if sol.status == QpStatus::Optimal && enough {
                break;
            }
            for w in &mut rho {
                *w *= 10.0;
            }
            sol = elastic::solve_elastic(h, g, &lin, &rho, &mut self.elastic_warm, tol);
            self.subproblem_multipliers(&mut sol.lambda, jac, &sol.d);
            iterations += sol.iterations;
        }
        // A failed subproblem keeps the weights (steering raised them in vain).
        if sol.status == QpStatus::Optimal {
            self.rho = rho;
        }
        StepChoice {
            qp: sol,
            elastic: true,
            infeasible_stationary: stationary && primal_bad,
            qp_iterations: iterations,
        }
    }

    /// Decrease of each row's linearized violation along d.
    fn row_reductions(&self, point: &Point, jac: &CsrMatrix<f64>, d: &[f64]) -> Vec<f64> {
        let (dl, du, bl, bu) = self.bounds_of_step(point);
        let lin = Linearization {
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        lin.row_reductions(d)
    }

    fn kkt(&self, point: &Point, jac: &CsrMatrix<f64>, lambda: &[f64]) -> (Kkt, Vec<f64>) {
        termination::measure(&KktInput {
            x: &point.x,
            xl: &self.ev.xl,
            xu: &self.ev.xu,
            c: &point.values.c,
            cl: &self.ev.cl,
            cu: &self.ev.cu,
            scale_c: &self.ev.scale_c,
            grad: &point.derivatives.grad,
            jac,
            lambda,
        })
    }

    /// x + αd, clamped into the bounds (the QP respects them; this removes rounding).
    fn trial(&self, x: &[f64], d: &[f64], alpha: f64) -> Vec<f64> {
        (0..x.len())
            .map(|j| (x[j] + alpha * d[j]).clamp(self.ev.xl[j], self.ev.xu[j]))
            .collect()
    }

    /// Evaluates values and derivatives at a trial point: Ok(None) for a domain failure.
    fn evaluate(&mut self, x: Vec<f64>) -> Result<Option<(Values, Vec<f64>)>, ()> {
        match self.ev.values(&x) {
            Ok(v) => Ok(Some((v, x))),
            Err(EvalError::Domain(_)) => Ok(None),
            Err(EvalError::Fatal(_)) => Err(()),
        }
    }

    fn complete(&mut self, x: Vec<f64>, values: Values) -> Result<Option<Point>, ()> {
        match self.ev.derivatives(&x) {
            Ok(derivatives) => Ok(Some(Point {
                x,
                values,
                derivatives,
            })),
            Err(EvalError::Domain(_)) => Ok(None),
            Err(EvalError::Fatal(_)) => Err(()),
        }
    }

    /// Whether values at `x + αd` pass the sufficient-decrease tests: Armijo on φ and, when
    /// asked, on the violation, each relaxed by the noise of the compared values (Berahas,
    /// Byrd & Nocedal, "Derivative-free optimization of noisy functions via quasi-Newton
    /// methods", SIAM J. Optim. 29(2), 2019, relaxed Armijo condition).
    fn accepts(&self, test: &Acceptance, values: &Values, alpha: f64) -> bool {
        let merit_ok = self.merit(values)
            <= test.phi0 + self.tuning.armijo * alpha * test.slope + test.merit_noise;
        let violation = merit::l1_violation(&values.c, &self.ev.cl, &self.ev.cu);
        let violation_ok = violation <= test.violation_cap
            && test.violation_slope.is_none_or(|vs| {
                violation <= test.v0 + self.tuning.armijo * alpha * vs + test.violation_noise
            });
        merit_ok && violation_ok
    }

    /// Measures the noise of φ and of the ℓ1 violation along d at `point` from
    /// [`noise::SAMPLES`] points spaced so that each moves x by about 1e-6·(1 + ‖x‖∞) (×100,
    /// twice, while the samples show no variation at all, as a coarsely quantized φ does; see
    /// `noise`), and widens the tests' allowances to three standard deviations. Returns `Err`
    /// on a fatal evaluation error; a failed evaluation leaves the tests as they are.
    fn measure_noise(&mut self, point: &Point, d: &[f64], test: &mut Acceptance) -> Result<(), ()> {
        test.noise_measured = true;
        let dnorm = d.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let xnorm = point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
        let mut spacing = self.tuning.noise_spacing * xnorm / dnorm;
        for _ in 0..3 {
            let mut merits = Vec::with_capacity(noise::SAMPLES);
            let mut violations = Vec::with_capacity(noise::SAMPLES);
            for k in 0..noise::SAMPLES {
                let x = self.trial(&point.x, d, k as f64 * spacing);
                let Some((values, _)) = self.evaluate(x)? else {
                    return Ok(());
                };
                merits.push(self.merit(&values));
                violations.push(merit::l1_violation(&values.c, &self.ev.cl, &self.ev.cu));
            }
            let (Some(sm), Some(sv)) =
                (noise::noise_level(&merits), noise::noise_level(&violations))
            else {
                return Ok(());
            };
            if sm > 0.0 || sv > 0.0 {
                test.merit_noise = test.merit_noise.max(self.tuning.noise_allowance * sm);
                test.violation_noise = test.violation_noise.max(self.tuning.noise_allowance * sv);
                if self.options.verbosity >= 2 {
                    self.say(&format!(
                        "      noise along d: merit {sm:.2e}, violation {sv:.2e} (slope {:.2e})",
                        test.slope
                    ));
                }
                return Ok(());
            }
            spacing *= 100.0;
        }
        Ok(())
    }

    fn line_search(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
        slope: f64,
        violation_slope: Option<f64>,
    ) -> LineSearch {
        let phi0 = self.merit(&point.values);
        // When the predicted decrease of the full step is itself at the rounding level of φ
        // (near a solution of a problem with a large objective), changes within 10·ε_mach·|φ₀|
        // count as no increase (IPOPT's relaxation), or the line search could only fail.
        let resolution = 10.0 * f64::EPSILON * phi0.abs();
        let v0 = merit::l1_violation(&point.values.c, &self.ev.cl, &self.ev.cu);
        let mut test = Acceptance {
            phi0,
            slope,
            v0,
            violation_slope,
            violation_cap: if self.model.is_quasi_newton() {
                f64::INFINITY
            } else {
                self.tuning.violation_growth * v0.max(self.tuning.violation_floor)
            },
            merit_noise: if -slope <= 100.0 * resolution {
                resolution
            } else {
                0.0
            },
            violation_noise: 0.0,
            noise_measured: false,
        };
        let dnorm = d.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let xnorm = point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
        if dnorm <= 1e-15 * xnorm {
            return LineSearch::Failed;
        }
        let first_alpha = (self.tuning.step_limit * (1.0 + xnorm) / dnorm).min(1.0);
        let mut alpha = first_alpha;
        let mut soc_tried = false;
        loop {
            if alpha < self.tuning.min_step {
                // Before giving up, find out whether φ is too noisy to resolve the predicted
                // decrease at all (an objective that cancels to f ≈ 0 has no |φ|-based
                // resolution); if it is, search again with the relaxed tests.
                if test.noise_measured {
                    break;
                }
                if self.measure_noise(point, d, &mut test).is_err() {
                    return LineSearch::Fatal;
                }
                if test.merit_noise == 0.0 && test.violation_noise == 0.0 {
                    break;
                }
                alpha = first_alpha;
                soc_tried = true;
            }
            let x = self.trial(&point.x, d, alpha);
            let Ok(evaluated) = self.evaluate(x) else {
                return LineSearch::Fatal;
            };
            let Some((values, x)) = evaluated else {
                alpha *= 0.25;
                continue;
            };
            let phi = self.merit(&values);
            let mut accepted = self.accepts(&test, &values, alpha);
            // A rejection where the predicted decrease is near the rounding level of φ: measure
            // how noisy φ really is (sums of many terms are far noisier than ε_mach·|φ|).
            if !accepted
                && !test.noise_measured
                && -alpha * slope <= self.tuning.noise_trigger * resolution.max(f64::MIN_POSITIVE)
            {
                if self.measure_noise(point, d, &mut test).is_err() {
                    return LineSearch::Fatal;
                }
                accepted = self.accepts(&test, &values, alpha);
            }
            if accepted {
                match self.complete(x, values) {
                    Err(()) => return LineSearch::Fatal,
                    Ok(Some(next)) => return LineSearch::Accepted { point: next, alpha },
                    Ok(None) => {
                        alpha *= 0.25;
                        continue;
                    }
                }
            }
            if alpha == 1.0 && !soc_tried {
                soc_tried = true;
                match self.second_order_correction(point, jac, d, &values, &test) {
                    Err(()) => return LineSearch::Fatal,
                    Ok(Some(next)) => return LineSearch::Accepted { point: next, alpha },
                    Ok(None) => {}
                }
            }
            // Safeguarded minimizer of the quadratic through φ(0), φ'(0), φ(α).
            let denom = 2.0 * (phi - phi0 - slope * alpha);
            let interp = if denom > 0.0 && phi.is_finite() {
                -slope * alpha * alpha / denom
            } else {
                0.1 * alpha
            };
            alpha = interp.clamp(0.1 * alpha, 0.5 * alpha);
        }
        LineSearch::Failed
    }

    /// One trust-region trial (Fletcher's Sℓ1QP; Nocedal & Wright, 2nd ed., Algorithm 18.4):
    /// the step d, already bounded by the radius, is accepted when the merit function falls
    /// by at least [`Tuning::armijo`] times the decrease the model predicts,
    /// `pred = −(slope + ½dᵀHd)` (slope = ∇fᵀd − Σρᵢ·(linearized decrease of row i)),
    /// or else after one second-order correction. The radius then grows ×2 when the ratio of
    /// actual to predicted decrease exceeds 0.75 on a step at the radius, and shrinks to half
    /// the step when it is below 0.25. A rejected step shrinks the radius to the minimizer of
    /// the quadratic through φ(0), its slope and φ(x + d), within [0.1, 0.5]·‖d‖∞, and the
    /// iteration is repeated at the same point; `Failed` once the radius falls below
    /// [`Tuning::min_radius`]·(1 + ‖x‖∞). With the exact Hessian the violation cap of the line
    /// search applies too.
    fn trust_region_step(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
        slope: f64,
        dhd: f64,
    ) -> LineSearch {
        let dnorm = d.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let xnorm = point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
        if dnorm <= 1e-15 * xnorm {
            return LineSearch::Failed;
        }
        let radius = self.effective_radius(point);
        if radius < self.tuning.min_radius * xnorm {
            return LineSearch::Failed;
        }
        let predicted = -(slope + 0.5 * dhd.max(0.0));
        let phi0 = self.merit(&point.values);
        let v0 = merit::l1_violation(&point.values.c, &self.ev.cl, &self.ev.cu);
        let test = Acceptance {
            phi0,
            slope: -predicted,
            v0,
            violation_slope: None,
            violation_cap: if self.model.is_quasi_newton() {
                f64::INFINITY
            } else {
                self.tuning.violation_growth * v0.max(self.tuning.violation_floor)
            },
            merit_noise: 10.0 * f64::EPSILON * phi0.abs(),
            violation_noise: 0.0,
            noise_measured: false,
        };
        let x = self.trial(&point.x, d, 1.0);
        let Ok(evaluated) = self.evaluate(x) else {
            return LineSearch::Fatal;
        };
        let mut phi = f64::INFINITY;
        if let Some((values, x)) = evaluated {
            phi = self.merit(&values);
            if self.accepts(&test, &values, 1.0) {
                let ratio = (phi0 - phi) / predicted;
                match self.complete(x, values) {
                    Err(()) => return LineSearch::Fatal,
                    Ok(Some(next)) => {
                        if ratio > 0.75 && dnorm >= 0.8 * radius {
                            self.radius = 2.0 * radius;
                        } else if ratio < 0.25 {
                            self.radius = 0.5 * dnorm;
                        }
                        self.log_radius(ratio);
                        return LineSearch::Accepted {
                            point: next,
                            alpha: 1.0,
                        };
                    }
                    Ok(None) => {}
                }
            } else {
                match self.second_order_correction(point, jac, d, &values, &test) {
                    Err(()) => return LineSearch::Fatal,
                    Ok(Some(next)) => {
                        self.log_radius(f64::NAN);
                        return LineSearch::Accepted {
                            point: next,
                            alpha: 1.0,
                        };
                    }
                    Ok(None) => {}
                }
            }
        }
        let denom = 2.0 * (phi - phi0 + predicted);
        let shrink = if denom > 0.0 && phi.is_finite() {
            predicted / denom
        } else {
            0.1
        };
        self.radius = shrink.clamp(0.1, 0.5) * dnorm;
        self.log_radius((phi0 - phi) / predicted);
        if self.radius < self.tuning.min_radius * xnorm {
            return LineSearch::Failed;
        }
        LineSearch::Rejected
    }

    /// Verbosity 2: the trust-region ratio of the last trial and the new radius.
    fn log_radius(&self, ratio: f64) {
        if self.options.verbosity >= 2 {
            self.say(&format!(
                "      trust region: ratio {ratio:.3e}, radius {:.3e}",
                self.radius
            ));
        }
    }

    /// The corrected step `x + d + p` with p from the QP whose constraint bounds are shifted
    /// by `c(x+d) − c(x) − J d`. Returns the accepted point, if the merit test passes.
    fn second_order_correction(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
        trial_values: &Values,
        test: &Acceptance,
    ) -> Result<Option<Point>, ()> {
        let (dl, du, mut bl, mut bu) = self.step_box(point);
        let jd = jac * &DVector::from_column_slice(d);
        for i in 0..bl.len() {
            let shift = trial_values.c[i] - point.values.c[i] - jd[i];
            bl[i] -= shift;
            bu[i] -= shift;
        }
        let problem = QpProblem {
            h: self.model.qp_hessian(),
            g: &point.derivatives.grad,
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        let saved = self.warm.snapshot();
        let tol = self.qp_tolerance();
        let sol = qp::solve(&problem, &mut self.warm, tol);
        self.warm.restore(saved);
        if sol.status != QpStatus::Optimal {
            return Ok(None);
        }
        let x = self.trial(&point.x, &sol.d, 1.0);
        let Some((values, x)) = self.evaluate(x)? else {
            return Ok(None);
        };
        if self.accepts(test, &values, 1.0) {
            return self.complete(x, values);
        }
        Ok(None)
    }

    /// Assembles the exact Hessian at `point` with the current multipliers (exact mode only).
    fn update_exact(&mut self, point: &Point) -> Result<(), EvalError> {
        let Model::Exact { .. } = self.model else {
            return Ok(());
        };
        let n = self.ev.dims.n;
        let sparse_qp = self.sparse_qp();
        let values = self.ev.hessian(&point.x, &self.lambda)?;
        let held = hessian::held_at_bounds(
            &point.x,
            &self.ev.xl,
            &self.ev.xu,
            &self.lagrangian_gradient(point),
        );
        let (rows, cols) = (&self.ev.hess_rows, &self.ev.hess_cols);
        let Model::Exact {
            shift,
            dense,
            sparse,
            row_weights,
            inertia,
        } = &mut self.model
        else {
            unreachable!()
        };
        if !sparse_qp {
            let h =
                hessian::decouple_dense(&hessian::assemble_dense(n, rows, cols, &values), &held);
            // Rows expected active: equalities (first) and rows with a nonzero multiplier.
            let is_equality = |i: usize| self.ev.cl[i] == self.ev.cu[i];
            let active: Vec<usize> = (0..self.ev.dims.m)
                .filter(|&i| is_equality(i))
                .chain((0..self.ev.dims.m).filter(|&i| !is_equality(i) && self.lambda[i] != 0.0))
                .collect();
            let equalities = active.iter().filter(|&&i| is_equality(i)).count();
            let mut position = vec![usize::MAX; self.ev.dims.m];
            for (k, &i) in active.iter().enumerate() {
                position[i] = k;
            }
            let mut a = DMatrix::zeros(active.len(), n);
            for (k, (&r, &c)) in self.jac_shape.0.iter().zip(&self.jac_shape.1).enumerate() {
                if position[r] != usize::MAX {
                    a[(position[r], c)] += point.derivatives.jac[k];
                }
            }
            let floor = self.warm.shift_floor();
            let convexified = shift
                .convexify_with_rows(&h, &a, equalities, floor)
                .ok_or_else(|| EvalError::Domain("Hessian not finite".into()))?;
            if self.options.verbosity >= 2 {
                self.live.borrow_mut().message(&format!(
                    "      Hessian shift {:.2e} (augmented rows: {}, held at bounds: {}, weight {:.2e})",
                    convexified.shift,
                    a.nrows(),
                    held.len(),
                    convexified.row_weight
                ));
            }
            *inertia = convexified.shift * hessian::scale_of(&h);
            *row_weights = convexified
                .weighted
                .iter()
                .filter_map(|&k| {
                    let norm2 = a.row(k).norm_squared();
                    (convexified.row_weight > 0.0 && norm2 > 0.0).then(|| {
                        let i = active[k];
                        (i, convexified.row_weight / norm2, is_equality(i))
                    })
                })
                .collect();
            *dense = Some(convexified.matrix);
        } else {
            let worst = point
                .values
                .c
                .iter()
                .zip(self.ev.cl.iter().zip(&self.ev.cu))
                .fold(0.0_f64, |a, (&c, (&l, &u))| a.max(l - c).max(c - u));
            let held = if worst > self.tuning.held_violation {
                Vec::new()
            } else {
                held
            };
            if self.options.verbosity >= 2 {
                self.live
                    .borrow_mut()
                    .message(&format!("      held at bounds: {}", held.len()));
            }
            let (r, c, v) = hessian::decouple_triplets(n, rows, cols, &values, &held);
            *sparse = Some(hessian::assemble_sparse_lower(n, &r, &c, &v));
        }
        Ok(())
    }

    /// Quasi-Newton update with the step `prev → next` at the new multipliers, or the exact
    /// Hessian at `next`.
    fn update_model(&mut self, prev: &Point, next: &Point) -> Result<(), EvalError> {
        if !self.model.is_quasi_newton() {
            return self.update_exact(next);
        }
        let s: Vec<f64> = next.x.iter().zip(&prev.x).map(|(a, b)| a - b).collect();
        let gl_next = self.lagrangian_gradient(next);
        let gl_prev = self.lagrangian_gradient(prev);
        let y: Vec<f64> = gl_next.iter().zip(&gl_prev).map(|(a, b)| a - b).collect();
        match &mut self.model {
            Model::Bfgs(b) => b.update(&s, &y),
            Model::Lbfgs(l) => l.update(&s, &y),
            Model::Exact { .. } => {}
        }
        Ok(())
    }

    fn lagrangian_gradient(&self, p: &Point) -> Vec<f64> {
        let mut g = p.derivatives.grad.clone();
        for (k, (&r, &c)) in self.jac_shape.0.iter().zip(&self.jac_shape.1).enumerate() {
            g[c] += self.lambda[r] * p.derivatives.jac[k];
        }
        g
    }

    fn record(&mut self, iter: usize, point: &Point, kkt: Kkt, step: f64, qp_iterations: usize) {
        let target = &self.options.log;
        let r = IterationRecord {
            stage: target.stage.clone(),
            iter,
            objective: point.values.f / self.ev.scale_f * target.objective.scale,
            infeasibility: self.ev.max_violation(&point.x, &point.values.c),
            optimality: kkt.optimality,
            step,
            merit: self.merit(&point.values),
            qp_iterations,
            elapsed: self.elapsed(),
        };
        self.live.borrow_mut().record(&r);
        if let Some(observer) = &target.observer {
            observer.observe(&r);
        }
        self.log.push(r);
    }

    fn finish(&mut self, status: Status, point: &Point, lambda: Option<&[f64]>) -> Solution {
        let jac = self.jacobian(&point.derivatives.jac);
        let lambda_scaled = lambda.map_or_else(|| self.lambda.clone(), |l| l.to_vec());
        let (kkt, z_scaled) = self.kkt(point, &jac, &lambda_scaled);
        let sf = self.ev.scale_f;
        let lambda = lambda_scaled
            .iter()
            .zip(&self.ev.scale_c)
            .map(|(l, s)| l * s / sf)
            .collect();
        let z = z_scaled.iter().map(|v| v / sf).collect();
        if self.options.verbosity >= 1 {
            self.say(status.sentence());
            if status == Status::Infeasible {
                self.say(&self.worst_rows(&point.values.c));
            }
        }
        Solution {
            status,
            x: point.x.clone(),
            lambda,
            z,
            objective: point.values.f / sf,
            constraints: self.ev.unscale_c(&point.values.c),
            max_violation: self.ev.max_violation(&point.x, &point.values.c),
            optimality: kkt.optimality,
            iterations: self.log.len().saturating_sub(1),
            evaluations: self.ev.counts,
            seconds: self.elapsed(),
            log: std::mem::take(&mut self.log),
        }
    }

    /// The most violated constraints by name, for infeasibility reports.
    fn worst_rows(&self, c_scaled: &[f64]) -> String {
        let mut rows: Vec<(usize, f64)> = (0..c_scaled.len())
            .map(|i| {
                let v = merit::row_violation(c_scaled[i], self.ev.cl[i], self.ev.cu[i]);
                (i, v / self.ev.scale_c[i])
            })
            .filter(|&(_, v)| v > self.options.constraint_tolerance)
            .collect();
        rows.sort_by(|a, b| b.1.total_cmp(&a.1));
        let list: Vec<String> = rows
            .iter()
            .take(5)
            .map(|&(i, v)| format!("{} by {v:.3e}", self.ev.constraint_name(i)))
            .collect();
        format!("most violated: {}", list.join(", "))
    }

    /// The result when the start cannot be evaluated.
    fn failed_start(&mut self, status: Status, x: Vec<f64>) -> Solution {
        if self.options.verbosity >= 1 {
            self.say(status.sentence());
        }
        let (n, m) = (self.ev.dims.n, self.ev.dims.m);
        Solution {
            status,
            x,
            lambda: vec![0.0; m],
            z: vec![0.0; n],
            objective: f64::NAN,
            constraints: vec![f64::NAN; m],
            max_violation: f64::INFINITY,
            optimality: f64::INFINITY,
            iterations: 0,
            evaluations: self.ev.counts,
            seconds: self.elapsed(),
            log: Vec::new(),
        }
    }
}
