//! The line-search phase: backtracking Armijo on the ℓ1 merit function with one second-order
//! correction, a violation test for steps that must reduce the violation, and tests relaxed by
//! the measured noise of φ (see `noise`).

use nalgebra::DVector;
use nalgebra_sparse::CsrMatrix;

#[cfg(doc)]
use super::super::Tuning;
use super::super::evaluator::Values;
use super::super::merit;
use super::super::noise;
use super::super::qp::{self, QpStatus};
use super::Sqp;
use super::state::Point;

/// The sufficient-decrease tests of one line search.
pub(super) struct Acceptance {
    /// Merit value at the current point.
    pub(super) phi0: f64,
    /// Upper bound of the merit function's directional derivative along d.
    pub(super) slope: f64,
    /// ℓ1 violation at the current point.
    pub(super) v0: f64,
    /// Predicted violation change along d when the violation must decrease in fact.
    pub(super) violation_slope: Option<f64>,
    /// Largest ℓ1 violation accepted at a trial point (see [`Tuning::violation_growth`]).
    pub(super) violation_cap: f64,
    /// Change of φ that counts as no change: its rounding level.
    pub(super) merit_noise: f64,
    /// Change of the violation that counts as no change.
    pub(super) violation_noise: f64,
    /// Whether the noise of φ and of the violation has been measured along d.
    pub(super) noise_measured: bool,
}

/// How a line search or a trust-region trial ended.
pub(super) enum LineSearch {
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

impl Sqp<'_> {
    pub(super) fn line_search(
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

    /// Whether values at `x + αd` pass the sufficient-decrease tests: Armijo on φ and, when
    /// asked, on the violation, each relaxed by the noise of the compared values (Berahas,
    /// Byrd & Nocedal, "Derivative-free optimization of noisy functions via quasi-Newton
    /// methods", SIAM J. Optim. 29(2), 2019, relaxed Armijo condition).
    pub(super) fn accepts(&self, test: &Acceptance, values: &Values, alpha: f64) -> bool {
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
    pub(super) fn measure_noise(
        &mut self,
        point: &Point,
        d: &[f64],
        test: &mut Acceptance,
    ) -> Result<(), ()> {
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

    /// The corrected step: the QP's step d̃ with its constraint bounds shifted by
    /// `c(x+s) − c(x) − J s`, first for s = d, then (up to `Options::second_order_corrections`
    /// in all) for s the last d̃, as long as each corrected point's ℓ1 violation is at most
    /// 0.99 of the one before (Wächter & Biegler 2006, §2.4). Returns the first corrected
    /// point that passes the merit test.
    pub(super) fn second_order_correction(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        d: &[f64],
        trial_values: &Values,
        test: &Acceptance,
    ) -> Result<Option<Point>, ()> {
        let rounds = self.options.second_order_corrections.unwrap_or(1);
        let tol = self.qp_tolerance();
        let mut step = d.to_vec();
        let mut values = trial_values.clone();
        let mut violation = merit::l1_violation(&values.c, &self.ev.cl, &self.ev.cu);
        for _ in 0..rounds {
            let mut bounds = self.step_box(point);
            let jd = jac * &DVector::from_column_slice(&step);
            for i in 0..bounds.bl.len() {
                let shift = values.c[i] - point.values.c[i] - jd[i];
                bounds.bl[i] -= shift;
                bounds.bu[i] -= shift;
            }
            let problem = bounds.problem(self.model.qp_hessian(), &point.derivatives.grad, jac);
            let sol = match &self.newton_base {
                // A Newton step on the active set is corrected on the same active set.
                Some(base) => {
                    let Some(sol) = self.warm.newton_step(&problem, base, tol) else {
                        return Ok(None);
                    };
                    sol
                }
                _ => {
                    let saved = self.warm.snapshot();
                    let sol = qp::solve(&problem, &mut self.warm, tol);
                    self.warm.restore(saved);
                    sol
                }
            };
            if sol.status != QpStatus::Optimal {
                return Ok(None);
            }
            let x = self.trial(&point.x, &sol.d, 1.0);
            let Some((corrected, x)) = self.evaluate(x)? else {
                return Ok(None);
            };
            if self.accepts(test, &corrected, 1.0) {
                return self.complete(x, corrected);
            }
            // Another correction only while this one lowered the violation by 1 % or more.
            let lowered = merit::l1_violation(&corrected.c, &self.ev.cl, &self.ev.cu);
            if lowered > 0.99 * violation {
                return Ok(None);
            }
            violation = lowered;
            step = sol.d;
            values = corrected;
        }
        Ok(None)
    }
}
