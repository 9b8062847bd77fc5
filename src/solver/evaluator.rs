//! The solver's view of an [`Nlp`]: bounds, automatic scaling, evaluation counts, a cache of
//! the last evaluated point, and conversion of non-finite values into domain errors.
//!
//! Scaling (Wächter & Biegler 2006, §3.8, gradient-based): at the start point
//! `s_f = min(1, 100/‖∇f‖∞)` and `sᵢ = min(1, 100/‖∇cᵢ‖∞)`, so no scaled gradient exceeds 100.
//! The solver works with `s_f·f` and `sᵢ·cᵢ` (and scaled bounds `sᵢ·clᵢ, sᵢ·cuᵢ`); everything
//! reported to the user is unscaled. Scaled multipliers λ̃ relate to the user's ones by
//! `λᵢ = λ̃ᵢ·sᵢ/s_f`, bound multipliers by `z = z̃/s_f`.

use super::{Dims, EvalError, Evaluations, Nlp};

/// Largest scaled gradient entry the scaling allows.
const GRADIENT_TARGET: f64 = 100.0;

/// Values at one point, scaled.
#[derive(Debug, Clone)]
pub struct Values {
    /// s_f·f.
    pub f: f64,
    /// sᵢ·cᵢ.
    pub c: Vec<f64>,
}

/// First derivatives at one point, scaled.
#[derive(Debug, Clone)]
pub struct Derivatives {
    /// s_f·∇f.
    pub grad: Vec<f64>,
    /// sᵢ·∂cᵢ/∂xⱼ in pattern order.
    pub jac: Vec<f64>,
}

/// Wraps the problem with scaling, counting and caching.
pub struct Evaluator<'a> {
    nlp: &'a dyn Nlp,
    /// Sizes.
    pub dims: Dims,
    /// Variable bounds.
    pub xl: Vec<f64>,
    /// Variable bounds.
    pub xu: Vec<f64>,
    /// Scaled constraint bounds.
    pub cl: Vec<f64>,
    /// Scaled constraint bounds.
    pub cu: Vec<f64>,
    /// Jacobian pattern rows.
    pub jac_rows: Vec<usize>,
    /// Jacobian pattern columns.
    pub jac_cols: Vec<usize>,
    /// Hessian pattern rows (empty without an exact Hessian).
    pub hess_rows: Vec<usize>,
    /// Hessian pattern columns.
    pub hess_cols: Vec<usize>,
    /// Objective scale s_f.
    pub scale_f: f64,
    /// Constraint scales sᵢ.
    pub scale_c: Vec<f64>,
    /// Counts of calls.
    pub counts: Evaluations,
    cache_values: Option<(Vec<f64>, Result<Values, EvalError>)>,
    cache_derivatives: Option<(Vec<f64>, Result<Derivatives, EvalError>)>,
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl<'a> Evaluator<'a> {
    /// Reads sizes, bounds and patterns; scaling starts as identity.
    pub fn new(nlp: &'a dyn Nlp) -> Self {
        let dims = nlp.dims();
        let (n, m) = (dims.n, dims.m);
        let (mut xl, mut xu) = (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n]);
        let (mut cl, mut cu) = (vec![f64::NEG_INFINITY; m], vec![f64::INFINITY; m]);
        nlp.bounds(&mut xl, &mut xu, &mut cl, &mut cu);
        let (mut jac_rows, mut jac_cols) = (vec![0; dims.jac_nnz], vec![0; dims.jac_nnz]);
        nlp.jacobian_structure(&mut jac_rows, &mut jac_cols);
        let (mut hess_rows, mut hess_cols) = (vec![0; dims.hess_nnz], vec![0; dims.hess_nnz]);
        if dims.hess_nnz > 0 {
            nlp.hessian_structure(&mut hess_rows, &mut hess_cols);
        }
        Evaluator {
            nlp,
            dims,
            xl,
            xu,
            cl,
            cu,
            jac_rows,
            jac_cols,
            hess_rows,
            hess_cols,
            scale_f: 1.0,
            scale_c: vec![1.0; m],
            counts: Evaluations::default(),
            cache_values: None,
            cache_derivatives: None,
        }
    }

    /// Whether the problem's own data are usable: consistent bounds and in-range patterns.
    pub fn check_input(&self) -> Result<(), String> {
        let (n, m) = (self.dims.n, self.dims.m);
        if let Some(j) = (0..n).find(|&j| self.xl[j] > self.xu[j] || self.xl[j].is_nan()) {
            return Err(format!("variable {j} has lower bound above upper bound"));
        }
        if let Some(i) = (0..m).find(|&i| self.cl[i] > self.cu[i] || self.cl[i].is_nan()) {
            return Err(format!(
                "constraint {} has lower bound above upper bound",
                self.nlp.constraint_name(i)
            ));
        }
        if self.jac_rows.iter().any(|&r| r >= m) || self.jac_cols.iter().any(|&c| c >= n) {
            return Err("Jacobian pattern out of range".into());
        }
        if self.hess_rows.iter().any(|&r| r >= n) || self.hess_cols.iter().any(|&c| c >= n) {
            return Err("Hessian pattern out of range".into());
        }
        Ok(())
    }

    /// The problem's starting point.
    pub fn start(&self) -> Vec<f64> {
        let mut x = vec![0.0; self.dims.n];
        self.nlp.start(&mut x);
        x
    }

    /// Chooses the scales from unscaled first derivatives at the start and rescales the
    /// constraint bounds. Call once, before any scaled quantity is used.
    pub fn set_scaling(&mut self, grad: &[f64], jac: &[f64]) {
        let gmax = grad.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
        self.scale_f = if gmax > GRADIENT_TARGET {
            GRADIENT_TARGET / gmax
        } else {
            1.0
        };
        let mut rmax = vec![0.0_f64; self.dims.m];
        for (k, &r) in self.jac_rows.iter().enumerate() {
            rmax[r] = rmax[r].max(jac[k].abs());
        }
        for (i, &r) in rmax.iter().enumerate() {
            let s = if r > GRADIENT_TARGET {
                GRADIENT_TARGET / r
            } else {
                1.0
            };
            self.scale_c[i] = s;
            self.cl[i] *= s;
            self.cu[i] *= s;
        }
        self.cache_values = None;
        self.cache_derivatives = None;
    }

    /// Scaled f and c at x (cached). Non-finite values become `EvalError::Domain`.
    pub fn values(&mut self, x: &[f64]) -> Result<Values, EvalError> {
        if let Some((cx, v)) = &self.cache_values
            && cx.as_slice() == x
        {
            return v.clone();
        }
        self.counts.functions += 1;
        let mut f = 0.0;
        let mut c = vec![0.0; self.dims.m];
        let result = match self.nlp.eval(x, &mut f, &mut c) {
            Err(e) => Err(e),
            Ok(()) if !f.is_finite() || !finite(&c) => {
                Err(EvalError::Domain("non-finite function value".into()))
            }
            Ok(()) => {
                for (ci, s) in c.iter_mut().zip(&self.scale_c) {
                    *ci *= s;
                }
                Ok(Values {
                    f: f * self.scale_f,
                    c,
                })
            }
        };
        self.cache_values = Some((x.to_vec(), result.clone()));
        result
    }

    /// Unscaled first derivatives (for choosing the scales).
    pub fn raw_derivatives(&mut self, x: &[f64]) -> Result<Derivatives, EvalError> {
        self.counts.derivatives += 1;
        let mut grad = vec![0.0; self.dims.n];
        let mut jac = vec![0.0; self.dims.jac_nnz];
        self.nlp.eval_derivatives(x, &mut grad, &mut jac)?;
        if !finite(&grad) || !finite(&jac) {
            return Err(EvalError::Domain("non-finite derivative".into()));
        }
        Ok(Derivatives { grad, jac })
    }

    /// Scaled first derivatives at x (cached).
    pub fn derivatives(&mut self, x: &[f64]) -> Result<Derivatives, EvalError> {
        if let Some((cx, d)) = &self.cache_derivatives
            && cx.as_slice() == x
        {
            return d.clone();
        }
        let result = self.raw_derivatives(x).map(|d| self.scaled(d));
        self.cache_derivatives = Some((x.to_vec(), result.clone()));
        result
    }

    /// Scaled first derivatives at x from the unscaled ones `raw` at x (cached, as from
    /// [`Self::derivatives`]): the evaluation that chose the scales ([`Self::set_scaling`])
    /// serves the start's scaled derivatives too, with no second evaluation.
    pub fn seed_derivatives(&mut self, x: &[f64], raw: Derivatives) -> Derivatives {
        let scaled = self.scaled(raw);
        self.cache_derivatives = Some((x.to_vec(), Ok(scaled.clone())));
        scaled
    }

    /// `d` scaled: the gradient by `scale_f`, each Jacobian entry by its row's scale.
    fn scaled(&self, mut d: Derivatives) -> Derivatives {
        for g in &mut d.grad {
            *g *= self.scale_f;
        }
        for (k, v) in d.jac.iter_mut().enumerate() {
            *v *= self.scale_c[self.jac_rows[k]];
        }
        d
    }

    /// Values of the scaled Lagrangian Hessian `s_f∇²f + Σ λ̃ᵢ sᵢ ∇²cᵢ` (pattern order).
    pub fn hessian(&mut self, x: &[f64], lambda_scaled: &[f64]) -> Result<Vec<f64>, EvalError> {
        self.counts.hessians += 1;
        let lambda: Vec<f64> = lambda_scaled
            .iter()
            .zip(&self.scale_c)
            .map(|(l, s)| l * s)
            .collect();
        let mut values = vec![0.0; self.dims.hess_nnz];
        self.nlp
            .eval_hessian(x, self.scale_f, &lambda, &mut values)?;
        if !finite(&values) {
            return Err(EvalError::Domain("non-finite Hessian".into()));
        }
        Ok(values)
    }

    /// Largest unscaled violation of bounds and constraints, given scaled c.
    pub fn max_violation(&self, x: &[f64], c_scaled: &[f64]) -> f64 {
        let mut v = 0.0_f64;
        for ((&x, &l), &u) in x.iter().zip(&self.xl).zip(&self.xu) {
            v = v.max(l - x).max(x - u);
        }
        for (((&c, &l), &u), &s) in c_scaled
            .iter()
            .zip(&self.cl)
            .zip(&self.cu)
            .zip(&self.scale_c)
        {
            v = v.max((l - c) / s).max((c - u) / s);
        }
        v
    }

    /// Unscaled constraint values.
    pub fn unscale_c(&self, c_scaled: &[f64]) -> Vec<f64> {
        c_scaled
            .iter()
            .zip(&self.scale_c)
            .map(|(c, s)| c / s)
            .collect()
    }

    /// The problem's name for a constraint row.
    pub fn constraint_name(&self, row: usize) -> String {
        self.nlp.constraint_name(row)
    }
}
