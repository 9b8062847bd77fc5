//! The step phase: the QP at the current point, and elastic mode when its linearization is
//! inconsistent or nearly so (see `elastic`), with the least-violation subproblem that tells a
//! stationary point of the violation.

use nalgebra_sparse::CsrMatrix;

use super::super::Globalization;
#[cfg(doc)]
use super::super::Tuning;
use super::super::elastic::{self, Linearization};
use super::super::hessian::Model;
use super::super::multipliers;
use super::super::qp::{self, QpHessian, QpProblem, QpSolution, QpStatus};
use super::Sqp;
use super::state::Point;

/// What the QP phase of an iteration produced.
pub(super) struct StepChoice {
    pub(super) qp: QpSolution,
    /// Whether the step came from the elastic subproblem.
    pub(super) elastic: bool,
    /// x is a stationary point of the violation while infeasible.
    pub(super) infeasible_stationary: bool,
    pub(super) qp_iterations: usize,
}

/// Bounds of a step d (scaled): `dl ≤ d ≤ du` and `bl ≤ J d ≤ bu`.
pub(super) struct StepBounds {
    pub(super) dl: Vec<f64>,
    pub(super) du: Vec<f64>,
    pub(super) bl: Vec<f64>,
    pub(super) bu: Vec<f64>,
}

impl StepBounds {
    /// The linearized constraints with Jacobian `a` within these bounds.
    pub(super) fn linearization<'b>(&'b self, a: &'b CsrMatrix<f64>) -> Linearization<'b> {
        Linearization {
            a,
            dl: &self.dl,
            du: &self.du,
            bl: &self.bl,
            bu: &self.bu,
        }
    }

    /// The QP `min ½dᵀHd + gᵀd` within these bounds.
    pub(super) fn problem<'b>(
        &'b self,
        h: QpHessian<'b>,
        g: &'b [f64],
        a: &'b CsrMatrix<f64>,
    ) -> QpProblem<'b> {
        QpProblem {
            h,
            g,
            a,
            dl: &self.dl,
            du: &self.du,
            bl: &self.bl,
            bu: &self.bu,
        }
    }
}

impl Sqp<'_> {
    /// Solves the QP at `point`, switching to elastic mode when it is inconsistent.
    pub(super) fn choose_step(&mut self, point: &Point, jac: &CsrMatrix<f64>) -> StepChoice {
        let bounds = self.step_box(point);
        let g = &point.derivatives.grad;
        let tol = self.qp_tolerance();
        let problem = bounds.problem(self.model.qp_hessian(), g, jac);
        let mut qp = qp::solve(&problem, &mut self.warm, tol);
        let stable = same_active_set(&mut self.active_signature, &qp);
        self.active_stable = if stable { self.active_stable + 1 } else { 0 };
        self.newton_base = None;
        if self.endgame_due()
            && let Some(newton) = self.warm.newton_step(&problem, &qp, tol)
        {
            if self.options.verbosity >= 2 {
                self.say("      Newton step on the active set");
            }
            self.newton_base = Some(std::mem::replace(&mut qp, newton));
        }
        self.subproblem_multipliers(&mut qp.lambda, jac, &qp.d);
        let lin = bounds.linearization(jac);
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
        // The QP's own step settles stationarity when it can (`reached_violation`).
        let stationarity_radius = Self::stationarity_radius(point);
        let certified = self
            .reached_violation(&lin, &qp, stationarity_radius)
            .filter(|&bound| now - bound > self.options.tolerance * now);
        let (stationary, least) = match certified {
            Some(bound) => (false, bound),
            None => self.violation_stationary(point, jac),
        };
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
        let least = if radius >= stationarity_radius {
            least
        } else if certified.is_some() {
            self.reached_violation(&lin, &qp, radius).unwrap_or(least)
        } else {
            self.least_violation(point, jac, radius).1.unwrap_or(least)
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

    /// Whether the step of this iteration is to be the exact Newton step on the QP's active set
    /// ([`qp::WarmStart::newton_step`]): with the exact Hessian on the sparse path under the line
    /// search, when the QP needed a convexification, no damping floor is in effect, no Newton
    /// step was refused at this point, and its active set is the one of the last
    /// [`Tuning::endgame_after`] QPs or the last step was a Newton step taken in full.
    fn endgame_due(&self) -> bool {
        matches!(self.model, Model::Exact { .. })
            && self.sparse_qp()
            && self.options.globalization == Globalization::LineSearch
            && self.tuning.endgame_after > 0
            && (self.active_stable >= self.tuning.endgame_after || self.endgame)
            && !self.endgame_refused
            && self.warm.shift_floor() == 0.0
            && !self.warm.convexification().is_zero()
    }

    /// A subproblem's multipliers in the problem's terms: the exact model's row weights
    /// undone, and void rows' multipliers set to 0 (`multipliers::clear_void_rows`).
    pub(super) fn subproblem_multipliers(
        &self,
        lambda: &mut [f64],
        jac: &CsrMatrix<f64>,
        d: &[f64],
    ) {
        self.model.restore_multipliers(lambda, jac, d);
        multipliers::clear_void_rows(jac, lambda);
    }

    /// Relative tolerance handed to the QP method (the sparse one stops at it; two orders
    /// tighter than the outer test so that QP multipliers do not limit the final accuracy).
    pub(super) fn qp_tolerance(&self) -> f64 {
        (0.01 * self.options.tolerance).clamp(1e-12, 1e-8)
    }

    /// The QP's step bounds: the variable bounds, and under the trust region the radius.
    pub(super) fn step_box(&self, point: &Point) -> StepBounds {
        let mut bounds = self.bounds_of_step(point);
        let radius = self.effective_radius(point);
        if radius.is_finite() {
            for (l, u) in bounds.dl.iter_mut().zip(bounds.du.iter_mut()) {
                *l = l.max(-radius);
                *u = u.min(radius);
            }
        }
        bounds
    }

    /// The bounds of a step from `point`: the variable bounds, and the constraint bounds
    /// less c.
    pub(super) fn bounds_of_step(&self, point: &Point) -> StepBounds {
        let x = &point.x;
        let c = &point.values.c;
        StepBounds {
            dl: x.iter().zip(&self.ev.xl).map(|(x, l)| l - x).collect(),
            du: x.iter().zip(&self.ev.xu).map(|(x, u)| u - x).collect(),
            bl: c.iter().zip(&self.ev.cl).map(|(c, l)| l - c).collect(),
            bu: c.iter().zip(&self.ev.cu).map(|(c, u)| u - c).collect(),
        }
    }

    /// Whether x is a stationary point of the ℓ1 violation: the least linearized violation
    /// within a box of radius Δ = max(1, ‖x‖∞) improves on the current one v by no more than
    /// `tolerance·v` (invariant under scaling of c; near a stationary point the reduction
    /// vanishes to first order). Also returns the least linearized violation.
    pub(super) fn violation_stationary(&self, point: &Point, jac: &CsrMatrix<f64>) -> (bool, f64) {
        let (now, least) = self.least_violation(point, jac, Self::stationarity_radius(point));
        match least {
            // Above v (d = 0 reaches v): the subproblem failed numerically.
            Some(least) if least <= now => (now - least <= self.options.tolerance * now, least),
            _ => (false, now),
        }
    }

    /// An upper bound on the least linearized ℓ1 violation within `|d|∞ ≤ radius` from the
    /// QP's own step, when the QP ended `Optimal` (its step meets the step's bounds;
    /// [`Linearization::violation_bound`]). A bound below `(1 − tolerance)·v` proves that x is
    /// not a stationary point of the violation without the least-violation subproblem, which
    /// is not to be trusted there: its Hessian is `1e-8·I`, and on the 0.5 m pier lattice (548
    /// variables, ~1,100 slacks) the dense method returned a "least" violation above the
    /// current one in 8 s, while the QP's step reached 1e-11; that read as a stationary point,
    /// and the solve retreated.
    fn reached_violation(&self, lin: &Linearization, qp: &QpSolution, radius: f64) -> Option<f64> {
        (qp.status == QpStatus::Optimal).then(|| lin.violation_bound(&qp.d, radius))
    }

    /// Radius of the box in which [`Self::violation_stationary`] looks for a lower violation:
    /// max(1, ‖x‖∞).
    pub(super) fn stationarity_radius(point: &Point) -> f64 {
        point.x.iter().fold(1.0_f64, |a, v| a.max(v.abs()))
    }

    /// The current linearized ℓ1 violation and the least one reachable within `|d|∞ ≤
    /// radius` and the variable bounds (None if that subproblem fails).
    pub(super) fn least_violation(
        &self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        radius: f64,
    ) -> (f64, Option<f64>) {
        let bounds = self.bounds_of_step(point);
        let lin = bounds.linearization(jac);
        let now = lin.violation_now();
        let mut warm = self.feasibility_warm.borrow_mut();
        let least = elastic::least_violation(&lin, radius, &mut warm, self.qp_tolerance())
            .map(|(least, _)| least);
        (now, least)
    }

    /// Decrease of each row's linearized violation along d.
    pub(super) fn row_reductions(
        &self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
    ) -> Vec<f64> {
        let bounds = self.bounds_of_step(point);
        let lin = bounds.linearization(jac);
        lin.row_reductions(d)
    }
}

/// Records the active set of `qp` (the signs of its bound and row multipliers; none when it
/// failed) in `signature`; true when it is the one recorded before.
fn same_active_set(signature: &mut Vec<i8>, qp: &QpSolution) -> bool {
    let now: Vec<i8> = if qp.status == QpStatus::Optimal {
        (qp.z.iter().chain(&qp.lambda))
            .map(|&v| (v > 0.0) as i8 - (v < 0.0) as i8)
            .collect()
    } else {
        Vec::new()
    };
    let same = !now.is_empty() && now == *signature;
    *signature = now;
    same
}
