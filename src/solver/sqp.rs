//! The SQP outer loop: a line-search Sℓ1QP method (Fletcher 1985; Nocedal & Wright, 2nd ed.,
//! Algorithm 18.3 with §18.5), on the automatically scaled problem (see `evaluator`).
//!
//! Each major iteration at x (all quantities scaled):
//! 1. QP `min ½dᵀHd + ∇fᵀd  s.t. xl−x ≤ d ≤ xu−x, cl−c ≤ J d ≤ cu−c` through [`qp::solve`],
//!    warm-started from the previous working set; bounds on x are constraints of the QP, so
//!    every iterate satisfies them exactly.
//! 2. If the QP is inconsistent: elastic mode (see `elastic`). The least reachable linearized
//!    violation is computed first; when none is reachable although x is infeasible, x is a
//!    stationary point of the violation and the solve ends `Infeasible`. Otherwise the
//!    elastic penalty is raised (×10) until the step achieves at least a tenth of the
//!    reachable reduction (steering).
//! 3. Termination tests at x with the QP multipliers (see `termination`).
//! 4. Penalty ρ of the ℓ1 merit `φ = f + ρ‖viol c‖₁` raised so that d is a descent direction
//!    (see `merit::required_penalty`); ρ never decreases.
//! 5. Backtracking Armijo line search on φ (η = 1e-4, safeguarded quadratic interpolation);
//!    if the unit step is rejected, one second-order correction (N&W eq. 18.51) re-solves the
//!    QP with the constraint bounds shifted by `c(x+d) − c(x) − J d`, against the Maratos
//!    effect. A failed or non-finite evaluation at a trial point only shortens the step.
//! 6. Hessian update (damped BFGS / L-BFGS) or exact Hessian at the new point with the new
//!    multipliers λ = λ_QP.
//!
//! Hessian choice in `HessianMode::Auto`: the exact Hessian when the problem has one; else
//! dense BFGS for n ≤ [`DENSE_BFGS_LIMIT`] (an n×n update costs O(n²) per iteration and the
//! dense QP O(n³) anyway), L-BFGS above.

use std::io::Write;
use std::sync::atomic::Ordering;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};

use super::elastic::{self, Linearization};
use super::evaluator::{Derivatives, Evaluator, Values};
use super::hessian::{self, DenseBfgs, InertiaShift, Lbfgs};
use super::log;
use super::merit;
use super::qp::{self, QpHessian, QpProblem, QpSolution, QpStatus, WarmStart};
use super::termination::{self, Kkt, KktInput};
use super::{EvalError, HessianMode, IterationRecord, Nlp, Options, Solution, Status};

/// Largest n for which `HessianMode::Auto` picks dense BFGS over L-BFGS.
pub const DENSE_BFGS_LIMIT: usize = 500;

/// Armijo constant of the line search.
const ARMIJO: f64 = 1e-4;
/// Smallest step length tried before the line search gives up.
const MIN_STEP: f64 = 1e-12;
/// Largest constraint force `|λᵢ|·‖∇cᵢ‖∞`, relative to `max(1, ‖∇f‖∞)`, accepted from the
/// ordinary QP; beyond it the linearization is treated as nearly inconsistent and the elastic
/// subproblem is solved instead (SNOPT switches on large multipliers likewise). At a regular
/// point the forces balance the objective gradient, so this only happens near degenerate or
/// infeasible points. Also the cap of the elastic weights.
const ELASTIC_WEIGHT: f64 = 1e4;
/// Largest step `‖αd‖∞` relative to `1 + ‖x‖∞` tried by the line search (SNOPT's major step
/// limit), so that a huge QP step cannot throw the iterate far away in one go.
const STEP_LIMIT: f64 = 2.0;
/// Elastic-penalty increases per iteration.
const MAX_STEERING: usize = 8;
/// Consecutive iterations within 100× the tolerances before `Acceptable`.
const ACCEPTABLE_ITERATIONS: usize = 15;

/// The second-order model in use.
enum Model {
    Bfgs(DenseBfgs),
    Lbfgs(Lbfgs),
    Exact {
        shift: InertiaShift,
        /// Dense convexified matrix (small n) or the raw lower triangle (large n).
        dense: Option<DMatrix<f64>>,
        sparse: Option<CscMatrix<f64>>,
    },
}

impl Model {
    fn qp_hessian(&self) -> QpHessian<'_> {
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
    fn dense(&self, n: usize) -> DMatrix<f64> {
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
                let h = hessian::assemble_dense(n, &r, &c, &v);
                InertiaShift::default()
                    .convexify(&h)
                    .map(|(m, _)| m)
                    .unwrap_or_else(|| DMatrix::identity(n, n))
            }
        }
    }

    /// H·d.
    fn times(&self, d: &[f64]) -> Vec<f64> {
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

    fn is_quasi_newton(&self) -> bool {
        !matches!(self, Model::Exact { .. })
    }

    fn reset(&mut self) {
        match self {
            Model::Bfgs(b) => b.reset(),
            Model::Lbfgs(l) => l.reset(),
            Model::Exact { .. } => {}
        }
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

enum LineSearch {
    Accepted { point: Point, alpha: f64 },
    Failed,
    Fatal,
}

struct Sqp<'a> {
    ev: Evaluator<'a>,
    options: &'a Options,
    started: Instant,
    log: Vec<IterationRecord>,
    model: Model,
    /// Penalty weights of the merit function, one per row.
    rho: Vec<f64>,
    lambda: Vec<f64>,
    warm: WarmStart,
    elastic_warm: WarmStart,
    jac_shape: (Vec<usize>, Vec<usize>),
}

/// Solves `nlp` from its starting point (see the module documentation for the method).
pub fn solve(nlp: &dyn Nlp, options: &Options) -> Solution {
    let started = Instant::now();
    let ev = Evaluator::new(nlp);
    let n = ev.dims.n;
    let mode = match options.hessian {
        HessianMode::Auto if ev.dims.hess_nnz > 0 => HessianMode::Exact,
        HessianMode::Auto if n <= DENSE_BFGS_LIMIT => HessianMode::Bfgs,
        HessianMode::Auto => HessianMode::Lbfgs,
        HessianMode::Exact if ev.dims.hess_nnz == 0 => HessianMode::Bfgs,
        other => other,
    };
    let model = match mode {
        HessianMode::Lbfgs => Model::Lbfgs(Lbfgs::new(n, options.lbfgs_memory)),
        HessianMode::Exact => Model::Exact {
            shift: InertiaShift::default(),
            dense: None,
            sparse: None,
        },
        _ => Model::Bfgs(DenseBfgs::new(n)),
    };
    let jac_shape = (ev.jac_rows.clone(), ev.jac_cols.clone());
    let m = ev.dims.m;
    let mut sqp = Sqp {
        lambda: vec![0.0; ev.dims.m],
        ev,
        options,
        started,
        log: Vec::new(),
        model,
        rho: vec![0.0; m],
        warm: WarmStart::default(),
        elastic_warm: WarmStart::default(),
        jac_shape,
    };
    sqp.run()
}

impl<'a> Sqp<'a> {
    fn elapsed(&self) -> f64 {
        self.started.elapsed().as_secs_f64()
    }

    fn say(&self, text: &str) {
        if self.options.verbosity >= 1 {
            let _ = writeln!(std::io::stderr(), "{text}");
        }
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
        for j in 0..x.len() {
            x[j] = x[j].clamp(self.ev.xl[j], self.ev.xu[j]);
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
            let _ = log::write_header(&mut std::io::stderr());
        }
        if let Err(e) = self.update_exact(&point) {
            let status = self.eval_status(&e);
            return self.finish(status, &point, None);
        }
        let mut alpha_in = 0.0;
        let mut qp_in = 0;
        let mut acceptable_run = 0;
        let mut reset_done = false;
        let mut iteration = 0;
        loop {
            let jac = self.jacobian(&point.derivatives.jac);
            let step = self.choose_step(&point, &jac);
            let lambda_qp = step.qp.lambda.clone();
            let (kkt, _) = self.kkt(&point, &jac, &lambda_qp);
            self.record(iteration, &point, kkt, alpha_in, qp_in);

            let tol = self.options.tolerance;
            let ctol = self.options.constraint_tolerance;
            if kkt.primal <= ctol && kkt.optimality <= tol {
                return self.finish(Status::Optimal, &point, Some(&lambda_qp));
            }
            if step.infeasible_stationary {
                return self.finish(Status::Infeasible, &point, Some(&lambda_qp));
            }
            if kkt.primal <= ctol && point.values.f / self.ev.scale_f < -1e20 {
                return self.finish(Status::Unbounded, &point, Some(&lambda_qp));
            }
            if kkt.primal <= 100.0 * ctol && kkt.optimality <= 100.0 * tol {
                acceptable_run += 1;
                if acceptable_run >= ACCEPTABLE_ITERATIONS {
                    return self.finish(Status::Acceptable, &point, Some(&lambda_qp));
                }
            } else {
                acceptable_run = 0;
            }
            if let Some(status) = self.limit_reached(iteration) {
                return self.finish(status, &point, Some(&lambda_qp));
            }
            if step.qp.status != QpStatus::Optimal {
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
            let dhd: f64 = self.model.times(d).iter().zip(d).map(|(a, b)| a * b).sum();
            let mut reduction = self.linear_reduction(&point, &jac, d);
            let mut slope = gd - reduction;
            for _ in 0..20 {
                if slope < 0.0 || reduction <= 0.0 {
                    break;
                }
                for w in &mut self.rho {
                    *w = 2.0 * *w + 1e-8;
                }
                reduction = self.linear_reduction(&point, &jac, d);
                slope = gd - reduction;
            }
            if self.options.verbosity >= 2 {
                self.say(&format!(
                    "      |d| = {:.3e}  g'd = {gd:.3e}  d'Hd = {dhd:.3e}  lin.red = {reduction:.3e}  max rho = {:.3e}  slope = {slope:.3e}  qp = {:?}",
                    d.iter().fold(0.0_f64, |a, v| a.max(v.abs())),
                    self.rho.iter().fold(0.0_f64, |a, v| a.max(*v)),
                    step.qp.status
                ));
            }

            match self.line_search(&point, &jac, d, slope) {
                LineSearch::Accepted { point: next, alpha } => {
                    reset_done = false;
                    self.lambda = lambda_qp;
                    if let Err(e) = self.update_model(&point, &next) {
                        let status = self.eval_status(&e);
                        return self.finish(status, &next, Some(&self.lambda.clone()));
                    }
                    point = next;
                    alpha_in = alpha;
                    qp_in = step.qp_iterations;
                }
                LineSearch::Fatal => {
                    return self.finish(Status::EvaluationError, &point, Some(&lambda_qp));
                }
                LineSearch::Failed => {
                    if self.model.is_quasi_newton() && !reset_done {
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
                        return self.finish(status, &point, Some(&lambda_qp));
                    }
                }
            }
            iteration += 1;
        }
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
        let (dl, du, bl, bu) = self.bounds_of_step(point);
        let lin = Linearization {
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        let now = lin.violation_now();
        let radius = point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
        match elastic::least_violation(&lin, radius, self.options.tolerance) {
            Some((least, _)) => (now - least <= self.options.tolerance * now, least),
            None => (false, now),
        }
    }

    /// Solves the QP at `point`, switching to elastic mode when it is inconsistent.
    fn choose_step(&mut self, point: &Point, jac: &CsrMatrix<f64>) -> StepChoice {
        let (dl, du, bl, bu) = self.bounds_of_step(point);
        let g = &point.derivatives.grad;
        let tol = self.options.tolerance;
        let problem = QpProblem {
            h: self.model.qp_hessian(),
            g,
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        let qp = qp::solve(&problem, &mut self.warm, tol);
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
        if qp.status == QpStatus::Optimal && force <= ELASTIC_WEIGHT * gmax {
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
        let h = self.model.dense(self.ev.dims.n);
        let floor = self
            .rho
            .iter()
            .chain(self.lambda.iter())
            .fold(1.0_f64, |a, v| a.max(v.abs()))
            .min(ELASTIC_WEIGHT);
        let mut rho: Vec<f64> = self
            .rho
            .iter()
            .map(|w| w.clamp(floor, ELASTIC_WEIGHT.max(floor)))
            .collect();
        let best_reduction = (now - least).max(0.0);
        let mut sol = elastic::solve_elastic(&h, g, &lin, &rho, &mut self.elastic_warm, tol);
        iterations += sol.iterations;
        for _ in 0..MAX_STEERING {
            let after = lin.violation_after(&sol.d);
            let enough = after <= 1e-12 * (1.0 + now) || now - after >= 0.1 * best_reduction;
            if sol.status == QpStatus::Optimal && enough {
                break;
            }
            for w in &mut rho {
                *w *= 10.0;
            }
            sol = elastic::solve_elastic(&h, g, &lin, &rho, &mut self.elastic_warm, tol);
            iterations += sol.iterations;
        }
        self.rho = rho;
        StepChoice {
            qp: sol,
            elastic: true,
            infeasible_stationary: stationary && primal_bad,
            qp_iterations: iterations,
        }
    }

    /// Weighted decrease of the linearized violation along d with the current weights.
    fn linear_reduction(&self, point: &Point, jac: &CsrMatrix<f64>, d: &[f64]) -> f64 {
        let (dl, du, bl, bu) = self.bounds_of_step(point);
        let lin = Linearization {
            a: jac,
            dl: &dl,
            du: &du,
            bl: &bl,
            bu: &bu,
        };
        lin.weighted_reduction(d, &self.rho)
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

    fn line_search(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
        slope: f64,
    ) -> LineSearch {
        let phi0 = self.merit(&point.values);
        let dnorm = d.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let xnorm = point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
        if dnorm <= 1e-15 * xnorm {
            return LineSearch::Failed;
        }
        let mut alpha = (STEP_LIMIT * (1.0 + xnorm) / dnorm).min(1.0);
        let mut soc_tried = false;
        while alpha >= MIN_STEP {
            let x = self.trial(&point.x, d, alpha);
            let Ok(evaluated) = self.evaluate(x) else {
                return LineSearch::Fatal;
            };
            let Some((values, x)) = evaluated else {
                alpha *= 0.25;
                continue;
            };
            let phi = self.merit(&values);
            if phi <= phi0 + ARMIJO * alpha * slope {
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
                match self.second_order_correction(point, jac, d, &values, phi0, slope) {
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

    /// The corrected step `x + d + p` with p from the QP whose constraint bounds are shifted
    /// by `c(x+d) − c(x) − J d`. Returns the accepted point, if the merit test passes.
    fn second_order_correction(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
        trial_values: &Values,
        phi0: f64,
        slope: f64,
    ) -> Result<Option<Point>, ()> {
        let (dl, du, mut bl, mut bu) = self.bounds_of_step(point);
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
        let mut warm = self.warm.clone();
        let sol = qp::solve(&problem, &mut warm, self.options.tolerance);
        if sol.status != QpStatus::Optimal {
            return Ok(None);
        }
        let x = self.trial(&point.x, &sol.d, 1.0);
        let Some((values, x)) = self.evaluate(x)? else {
            return Ok(None);
        };
        if self.merit(&values) <= phi0 + ARMIJO * slope {
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
        let values = self.ev.hessian(&point.x, &self.lambda)?;
        let (rows, cols) = (&self.ev.hess_rows, &self.ev.hess_cols);
        let Model::Exact {
            shift,
            dense,
            sparse,
        } = &mut self.model
        else {
            unreachable!()
        };
        if n <= qp::DENSE_LIMIT {
            let h = hessian::assemble_dense(n, rows, cols, &values);
            // Rows expected active: equalities and rows with a nonzero multiplier.
            let active: Vec<usize> = (0..self.ev.dims.m)
                .filter(|&i| self.ev.cl[i] == self.ev.cu[i] || self.lambda[i] != 0.0)
                .collect();
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
            let (m, delta) = shift
                .convexify_with_rows(&h, &a)
                .ok_or_else(|| EvalError::Domain("Hessian not finite".into()))?;
            if self.options.verbosity >= 2 {
                let _ = writeln!(
                    std::io::stderr(),
                    "      Hessian shift {delta:.2e} (augmented rows: {})",
                    a.nrows()
                );
            }
            *dense = Some(m);
        } else {
            *sparse = Some(hessian::assemble_sparse_lower(n, rows, cols, &values));
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
        let r = IterationRecord {
            iter,
            objective: point.values.f / self.ev.scale_f,
            infeasibility: self.ev.max_violation(&point.x, &point.values.c),
            optimality: kkt.optimality,
            step,
            merit: self.merit(&point.values),
            qp_iterations,
            elapsed: self.elapsed(),
        };
        if self.options.verbosity >= 1 {
            let _ = log::write_record(&mut std::io::stderr(), &r);
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
            self.say(&format!("{}", status.sentence()));
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
