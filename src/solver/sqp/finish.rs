//! The finish phase: termination tests, the iteration record, and the solution in the
//! problem's units (multipliers unscaled, the most violated rows named when infeasible).

use std::sync::atomic::Ordering;

use nalgebra_sparse::CsrMatrix;

#[cfg(doc)]
use super::super::Tuning;
use super::super::hessian::Model;
use super::super::log;
use super::super::merit;
use super::super::qp::QpStatus;
use super::super::termination::Kkt;
use super::super::{EvalError, IterationRecord, Solution, Status};
use super::state::{Point, State};
use super::step::StepChoice;
use super::{Next, Sqp};

impl Sqp<'_> {
    /// The termination tests at the current point, in order: optimal; infeasible (a stationary
    /// point of the violation, unless a retreat is left); unbounded (feasible within 100×
    /// the tolerance with f < [`Tuning::unbounded_objective`] or ‖x‖∞ >
    /// [`Tuning::unbounded_step`]); progress stopped at the acceptable level; a creep
    /// (`Options::progress_window`); a limit
    /// (interrupt, time, iterations). None: the iteration goes on.
    pub(super) fn termination(
        &mut self,
        state: &mut State,
        step: &StepChoice,
        kkt: Kkt,
        jac: &CsrMatrix<f64>,
    ) -> Option<Next> {
        if self.converged(kkt) {
            return Some(Next::Finish(Status::Optimal));
        }
        let tol = self.options.tolerance;
        let ctol = self.options.constraint_tolerance;
        if step.qp.status == QpStatus::Interrupted {
            return Some(Next::Finish(Status::Interrupted));
        }
        let infeasible = step.infeasible_stationary
            || (step.qp.status != QpStatus::Optimal
                && self.stalled_status(kkt, &state.point, jac) == Status::Infeasible);
        if infeasible {
            return Some(if self.retreat(state) {
                Next::Retry
            } else {
                Next::Finish(Status::Infeasible)
            });
        }
        let point = &state.point;
        let xnorm = point.x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        // Within 100× the constraint tolerance of feasibility, the level `Acceptable` uses.
        let near_feasible = kkt.primal <= 100.0 * ctol;
        if near_feasible
            && (point.values.f / self.ev.scale_f < self.tuning.unbounded_objective
                || xnorm > self.tuning.unbounded_step)
        {
            return Some(Next::Finish(Status::Unbounded));
        }
        if state
            .acceptable
            .stalled((kkt.primal / ctol).max(kkt.optimality / tol), self.tuning)
        {
            return Some(Next::Finish(Status::Acceptable));
        }
        // Near feasibility, not strict feasibility: a creep whose violation hovers around the
        // tolerance (warren_deck_linear's first round, 1e-6 to 1e-5) would restart the window
        // at every slightly infeasible iterate.
        if state.progress.creeping(
            near_feasible,
            state.point.values.f,
            self.options.progress_window,
            self.options.progress_tolerance,
            self.options.progress_stretch,
            self.options.progress_extrapolate,
        ) {
            return Some(Next::Finish(Status::SlowProgress));
        }
        self.limit_reached(state.iteration).map(Next::Finish)
    }

    /// Whether the KKT measures pass the tolerances (`Status::Optimal`).
    pub(super) fn converged(&self, kkt: Kkt) -> bool {
        kkt.primal <= self.options.constraint_tolerance && kkt.optimality <= self.options.tolerance
    }

    /// Stalled, unless x is infeasible and stationary for the violation (then Infeasible).
    pub(super) fn stalled_status(&self, kkt: Kkt, point: &Point, jac: &CsrMatrix<f64>) -> Status {
        if kkt.primal > self.options.constraint_tolerance && self.violation_stationary(point, jac).0
        {
            Status::Infeasible
        } else {
            Status::Stalled
        }
    }

    pub(super) fn limit_reached(&self, iteration: usize) -> Option<Status> {
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

    pub(super) fn eval_status(&self, e: &EvalError) -> Status {
        match e {
            EvalError::Fatal(_) | EvalError::Domain(_) => Status::EvaluationError,
        }
    }

    /// The size line before the column header (see `log::size_line`).
    pub(super) fn say_size(&self) {
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

    /// Logs the iteration at `state.point` (the step and QP iterations that led there).
    pub(super) fn record(&mut self, state: &State, kkt: Kkt) {
        let point = &state.point;
        let target = &self.options.log;
        let r = IterationRecord {
            stage: target.stage.clone(),
            iter: state.iteration,
            objective: point.values.f / self.ev.scale_f * target.objective.scale,
            infeasibility: self.ev.max_violation(&point.x, &point.values.c),
            optimality: kkt.optimality,
            step: state.alpha,
            merit: self.merit(&point.values),
            qp_iterations: state.qp_iterations,
            elapsed: self.elapsed(),
        };
        self.live.borrow_mut().record(&r);
        if let Some(observer) = &target.observer {
            observer.observe(&r);
        }
        self.log.push(r);
    }

    pub(super) fn finish(
        &mut self,
        status: Status,
        point: &Point,
        lambda: Option<&[f64]>,
    ) -> Solution {
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
    pub(super) fn worst_rows(&self, c_scaled: &[f64]) -> String {
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
    pub(super) fn failed_start(&mut self, status: Status, x: Vec<f64>) -> Solution {
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
