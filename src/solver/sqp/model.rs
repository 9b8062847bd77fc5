//! The model phase: the Hessian at the new point (damped BFGS / L-BFGS update, or the exact
//! Hessian decoupled from variables held at bounds and convexified), the shift floor that damps
//! cut exact steps, and the switch from the exact Hessian to a quasi-Newton model.

use nalgebra::DMatrix;

use super::super::EvalError;
#[cfg(doc)]
use super::super::Tuning;
use super::super::hessian::{self, DenseBfgs, Lbfgs, Model};
use super::Sqp;
use super::state::Point;

impl Sqp<'_> {
    /// Assembles the exact Hessian at `point` with the current multipliers (exact mode only).
    pub(super) fn update_exact(&mut self, point: &Point) -> Result<(), EvalError> {
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
            let (rows, cols) = self.jac_pattern.entries();
            for (k, (&r, &c)) in rows.iter().zip(cols).enumerate() {
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
            self.warm
                .keep_factor(convexified.matrix.clone(), convexified.factor);
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

    /// Quasi-Newton update with the step `prev → next` at the new multipliers; the exact
    /// Hessian at `next` is left due (`hessian_due`: evaluated when the next iteration's QP
    /// needs it, not when the solve ends on arrival there).
    pub(super) fn update_model(&mut self, prev: &Point, next: &Point) -> Result<(), EvalError> {
        if !self.model.is_quasi_newton() {
            self.hessian_due = true;
            return Ok(());
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
    pub(super) fn damp_exact_steps(&mut self, alpha: f64, dhd: f64, d: &[f64]) {
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

    /// Switches from the exact Hessian to the quasi-Newton model of `HessianMode::Auto` (dense
    /// BFGS or L-BFGS) when it cannot make progress: its curvature, scaled by diverging
    /// multipliers far from a solution, can freeze the steps, while a quasi-Newton model stays
    /// bounded. The penalty weights restart from the current multipliers.
    pub(super) fn abandon_exact_hessian(&mut self, why: &str) {
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
}
