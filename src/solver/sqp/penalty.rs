//! The penalty phase: weights ρᵢ of the ℓ1 merit `φ = f + Σ ρᵢ viol(cᵢ)` so that the QP step
//! descends on φ (Powell's update, then the Byrd–Nocedal safeguard; see `merit`), the step's
//! predicted descent, and the watch that drops an exact Hessian whose weights stay huge.

use nalgebra_sparse::CsrMatrix;

#[cfg(doc)]
use super::super::Tuning;
use super::super::merit;
use super::Sqp;
use super::state::{Point, State};
use super::step::StepChoice;

/// The step's predicted descent, as the globalization phases need it.
pub(super) struct Descent {
    /// dᵀ(H + δI)d: the curvature the QP used along d (δ: the sparse QP's convexification).
    pub(super) dhd: f64,
    /// Upper bound of the merit function's directional derivative along d.
    pub(super) slope: f64,
    /// Predicted violation change along d, when the violation must decrease in fact.
    pub(super) violation_slope: Option<f64>,
}

impl Sqp<'_> {
    /// Penalty weights so that d descends on the merit function, and the descent predicted.
    pub(super) fn penalty(
        &mut self,
        point: &Point,
        jac: &CsrMatrix<f64>,
        step: &StepChoice,
    ) -> Descent {
        let d = &step.qp.d;
        if !step.elastic {
            merit::powell_update(&mut self.rho, &step.qp.lambda);
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
        let rows = self.row_reductions(point, jac, d);
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
        let violation_slope =
            (predicted > 0.0 && (step.elastic || reduction >= -0.5 * slope)).then_some(-predicted);
        Descent {
            dhd,
            slope,
            violation_slope,
        }
    }

    /// Counts the iterations in a row with the exact Hessian and a penalty weight above
    /// [`Tuning::exact_weight_limit`], and abandons the exact Hessian after
    /// [`Tuning::exact_patience`] of them (curvature scaled by diverging multipliers freezes
    /// the steps).
    pub(super) fn watch_exact_weights(&mut self, state: &mut State) {
        if !self.model.is_quasi_newton()
            && self.rho.iter().any(|&w| w > self.tuning.exact_weight_limit)
        {
            state.heavy_weights += 1;
            if state.heavy_weights >= self.tuning.exact_patience {
                self.abandon_exact_hessian("the penalty weights stayed huge");
            }
        } else {
            state.heavy_weights = 0;
        }
    }
}
