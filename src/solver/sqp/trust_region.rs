//! The trust-region phase (Fletcher's Sℓ1QP proper, [`Globalization::TrustRegion`]): the
//! ratio test on the merit function, the radius, and the retry of a failed QP.

use nalgebra_sparse::CsrMatrix;

use super::super::Globalization;
#[cfg(doc)]
use super::super::Tuning;
use super::super::merit;
use super::super::termination::Kkt;
use super::line_search::{Acceptance, LineSearch};
use super::state::{Point, State};
use super::step::StepChoice;
use super::{Next, Sqp};

impl Sqp<'_> {
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
    pub(super) fn trust_region_step(
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
    pub(super) fn log_radius(&self, ratio: f64) {
        if self.options.verbosity >= 2 {
            self.say(&format!(
                "      trust region: ratio {ratio:.3e}, radius {:.3e}",
                self.radius
            ));
        }
    }

    /// The trust-region radius in effect at `point` (infinite under the line search).
    pub(super) fn effective_radius(&self, point: &Point) -> f64 {
        if self.options.globalization == Globalization::LineSearch {
            return f64::INFINITY;
        }
        let xnorm = point.x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        self.radius.min(self.tuning.step_limit * (1.0 + xnorm))
    }

    /// A QP that did not end `Optimal`: under the trust region the iteration is repeated with a
    /// fresh quasi-Newton model (an ill-conditioned one fails the dense QP's factorization),
    /// then with radii ×0.1 down to [`Tuning::qp_retry_radius`]·(1 + ‖x‖∞); otherwise the
    /// solve ends stalled (or infeasible).
    pub(super) fn failed_qp(
        &mut self,
        state: &mut State,
        step: &StepChoice,
        kkt: Kkt,
        jac: &CsrMatrix<f64>,
    ) -> Next {
        if self.options.verbosity >= 2 {
            self.say(&format!(
                "      QP ended {:?} (elastic: {})",
                step.qp.status, step.elastic
            ));
        }
        let xnorm = state.point.x.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        let radius = self.effective_radius(&state.point);
        if radius.is_finite() && radius > self.tuning.qp_retry_radius * (1.0 + xnorm) {
            if self.model.is_quasi_newton() && !state.model_reset {
                self.model.reset();
                state.model_reset = true;
            } else {
                self.radius = 0.1 * radius;
            }
            return Next::Retry;
        }
        Next::Finish(self.stalled_status(kkt, &state.point, jac))
    }
}
