//! A feasibility phase for the pose constraints: bound-constrained Levenberg–Marquardt on the
//! constraint violations, run before the SQP solve (`[trials] feasibility_first`).
//!
//! With `c(z)` the constraints of an [`Nlp`] and `cl ≤ c ≤ cu` their bounds, the residual of row
//! `i` is its signed violation `rᵢ = cᵢ − clamp(cᵢ, clᵢ, cuᵢ)` (units of the constraint), and the
//! phase minimizes `½‖r(z)‖²` over the variable box `xl ≤ z ≤ xu`. The Jacobian of `r` is that of
//! `c` on violated rows and zero on satisfied ones (Gauss–Newton on the active rows). Each step
//! solves the damped least-squares problem on the free variables `F`
//! ```text
//!   min_δ ‖r + J_F δ‖² + λ‖δ‖²   ⇒   δ = −J_Fᵀ (J_F J_Fᵀ + λI)⁻¹ r
//! ```
//! (the `m × m` dual form: the problems here have far fewer rows than variables, and for
//! `λ → 0` this is the minimum-norm Gauss–Newton step). A variable at a bound whose step points
//! out of the box leaves `F` and the step is recomputed; the step is finally clamped into the box.
//! The damping follows Nielsen's rule (Madsen, Nielsen & Tingleff 2004, "Methods for non-linear
//! least squares problems", §3.2): with the gain ratio
//! `ρ = (‖r‖² − ‖r(z+δ)‖²) / (‖r‖² − ‖r + Jδ‖²)`, a step with `ρ > 0` is taken and
//! `λ ← λ·max(1/3, 1 − (2ρ − 1)³)`; otherwise `λ ← λ·ν`, `ν ← 2ν` and the step is recomputed from
//! the same Jacobian. The damping is a trust region: where the rollout's dependence on the forces
//! is violently nonlinear (impacts, joint limits) the steps shrink until the linearization
//! predicts the change, instead of an ℓ1 merit's penalty weight growing without bound.
//!
//! The objective plays no part here; the SQP solve that follows starts from a point that meets
//! (or nearly meets) the constraints and lowers the effort from there.

use std::time::Instant;

use nalgebra::{DMatrix, DVector};

use crate::solver::log::LogTarget;
use crate::solver::{Evaluations, Nlp};

/// Limits of a feasibility phase.
#[derive(Debug, Clone)]
pub struct FeasibilitySettings {
    /// Stop once every violation is at most this (constraint units).
    pub target: f64,
    /// Jacobian evaluations allowed.
    pub max_iterations: usize,
    /// Wall-clock limit (s).
    pub max_time: f64,
    /// Where one line per iteration goes (nowhere by default).
    pub log: LogTarget,
}

/// The outcome of a feasibility phase.
#[derive(Debug, Clone, PartialEq)]
pub struct Feasibility {
    /// The final point (the best one found).
    pub z: Vec<f64>,
    /// Its largest violation (constraint units).
    pub max_violation: f64,
    /// Whether every violation reached `target`.
    pub reached: bool,
    /// Jacobian evaluations (iterations).
    pub iterations: usize,
    /// Function and derivative evaluation counts.
    pub evaluations: Evaluations,
}

/// Signed violations of `c` against `[cl, cu]`.
fn residuals(c: &[f64], cl: &[f64], cu: &[f64]) -> Vec<f64> {
    c.iter()
        .zip(cl.iter().zip(cu))
        .map(|(&v, (&lo, &hi))| v - v.clamp(lo, hi))
        .collect()
}

fn norm2(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

fn max_abs(r: &[f64]) -> f64 {
    r.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// The damped step (module header) for residuals `r`, dense Jacobian `jac` (m × n, zero rows
/// for satisfied constraints), damping `lambda`, at `z` within `[xl, xu]`; clamped into the box.
fn damped_step(
    jac: &DMatrix<f64>,
    r: &[f64],
    lambda: f64,
    z: &[f64],
    xl: &[f64],
    xu: &[f64],
) -> Option<Vec<f64>> {
    let (m, n) = jac.shape();
    let rv = DVector::from_column_slice(r);
    let mut free = vec![true; n];
    let mut step = vec![0.0; n];
    for _ in 0..=n {
        let mut jf = jac.clone();
        for j in (0..n).filter(|&j| !free[j]) {
            jf.column_mut(j).fill(0.0);
        }
        let mut a = &jf * jf.transpose();
        for i in 0..m {
            a[(i, i)] += lambda;
        }
        let y = a.cholesky()?.solve(&rv);
        let d = -(jf.transpose() * y);
        let mut changed = false;
        for j in 0..n {
            step[j] = d[j];
            let out = (z[j] <= xl[j] && d[j] < 0.0) || (z[j] >= xu[j] && d[j] > 0.0);
            if free[j] && out {
                free[j] = false;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    for j in 0..n {
        step[j] = (z[j] + step[j]).clamp(xl[j], xu[j]) - z[j];
    }
    Some(step)
}

/// Runs the feasibility phase on `nlp` from `z0` (module header).
pub fn restore<N: Nlp>(nlp: &N, z0: &[f64], settings: &FeasibilitySettings) -> Feasibility {
    let clock = Instant::now();
    let d = nlp.dims();
    let crate::solver::Bounds { xl, xu, cl, cu } = crate::solver::Bounds::of(nlp);
    let (mut rows, mut cols) = (vec![0; d.jac_nnz], vec![0; d.jac_nnz]);
    nlp.jacobian_structure(&mut rows, &mut cols);
    let mut evaluations = Evaluations::default();
    let evaluate = |z: &[f64], evaluations: &mut Evaluations| -> Option<Vec<f64>> {
        let (mut f, mut c) = (0.0, vec![0.0; d.m]);
        evaluations.functions += 1;
        nlp.eval(z, &mut f, &mut c).ok()?;
        Some(residuals(&c, &cl, &cu))
    };
    let mut z: Vec<f64> = z0
        .iter()
        .zip(xl.iter().zip(&xu))
        .map(|(v, (lo, hi))| v.clamp(*lo, *hi))
        .collect();
    let done = |z: Vec<f64>, r: &[f64], iterations: usize, evaluations: Evaluations| {
        let max_violation = max_abs(r);
        Feasibility {
            z,
            max_violation,
            reached: max_violation <= settings.target,
            iterations,
            evaluations,
        }
    };
    let Some(mut r) = evaluate(&z, &mut evaluations) else {
        return done(z, &[f64::INFINITY], 0, evaluations);
    };
    let (mut lambda, mut nu) = (f64::NAN, 2.0);
    let mut iterations = 0;
    let (mut g, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
    while max_abs(&r) > settings.target
        && iterations < settings.max_iterations
        && clock.elapsed().as_secs_f64() < settings.max_time
    {
        iterations += 1;
        evaluations.derivatives += 1;
        if nlp.eval_derivatives(&z, &mut g, &mut jac).is_err() {
            break;
        }
        let mut dense = DMatrix::<f64>::zeros(d.m, d.n);
        for k in 0..d.jac_nnz {
            if r[rows[k]] != 0.0 {
                dense[(rows[k], cols[k])] += jac[k];
            }
        }
        if lambda.is_nan() {
            let diag = (&dense * dense.transpose()).diagonal().max();
            lambda = 1e-3 * diag.max(1e-12);
        }
        let before = norm2(&r);
        let mut moved = false;
        while lambda < 1e20 {
            let Some(step) = damped_step(&dense, &r, lambda, &z, &xl, &xu) else {
                lambda *= nu;
                nu *= 2.0;
                continue;
            };
            let linear = &dense * DVector::from_column_slice(&step);
            let predicted = before
                - r.iter()
                    .zip(linear.iter())
                    .map(|(a, b)| (a + b) * (a + b))
                    .sum::<f64>();
            if predicted <= 1e-14 * before {
                if norm2(&step) <= 1e-28 * (1.0 + norm2(&z)) {
                    // Stationary for the violation within the box: damping cannot help.
                    break;
                }
                // Clamping into the box spoiled the step: shorten it.
                lambda *= nu;
                nu *= 2.0;
                continue;
            }
            let trial: Vec<f64> = z.iter().zip(&step).map(|(a, b)| a + b).collect();
            let rho = match evaluate(&trial, &mut evaluations) {
                Some(rt) => {
                    let rho = (before - norm2(&rt)) / predicted;
                    if rho > 0.0 {
                        z = trial;
                        r = rt;
                        moved = true;
                    }
                    rho
                }
                None => -1.0,
            };
            if moved {
                lambda *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
                nu = 2.0;
                break;
            }
            lambda *= nu;
            nu *= 2.0;
            if clock.elapsed().as_secs_f64() >= settings.max_time {
                break;
            }
        }
        settings.log.line(&format!(
            "feasibility {iterations:>4}: ‖r‖² {:.3e}  max {:.3e}  λ {lambda:.2e}  {:.1} s",
            norm2(&r),
            max_abs(&r),
            clock.elapsed().as_secs_f64()
        ));
        if !moved {
            break;
        }
    }
    for (i, v) in r
        .iter()
        .enumerate()
        .filter(|(_, v)| v.abs() > settings.target)
    {
        settings.log.line(&format!(
            "feasibility: {} violated by {v:+.3e}",
            nlp.constraint_name(i)
        ));
    }
    done(z, &r, iterations, evaluations)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solver::{Dims, EvalError};

    /// Rows `x₀² + x₁² = 1`, `x₀ − x₁ ≥ 0.5`, `x₂ ≤ 3`; box `x ∈ [−2, 2]³` except `x₁ ≤ 0.2`.
    struct Circle;

    impl Nlp for Circle {
        fn dims(&self) -> Dims {
            Dims {
                n: 3,
                m: 3,
                jac_nnz: 5,
                hess_nnz: 0,
            }
        }
        fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
            xl.fill(-2.0);
            xu.copy_from_slice(&[2.0, 0.2, 2.0]);
            cl.copy_from_slice(&[1.0, 0.5, f64::NEG_INFINITY]);
            cu.copy_from_slice(&[1.0, f64::INFINITY, 3.0]);
        }
        fn start(&self, x: &mut [f64]) {
            x.copy_from_slice(&[0.1, 0.1, 0.0]);
        }
        fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
            rows.copy_from_slice(&[0, 0, 1, 1, 2]);
            cols.copy_from_slice(&[0, 1, 0, 1, 2]);
        }
        fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
            *f = 0.0;
            c.copy_from_slice(&[x[0] * x[0] + x[1] * x[1], x[0] - x[1], x[2]]);
            Ok(())
        }
        fn eval_derivatives(
            &self,
            x: &[f64],
            g: &mut [f64],
            jac: &mut [f64],
        ) -> Result<(), EvalError> {
            g.fill(0.0);
            jac.copy_from_slice(&[2.0 * x[0], 2.0 * x[1], 1.0, -1.0, 1.0]);
            Ok(())
        }
    }

    /// The phase reaches a point meeting every row within the target, inside the box, and a
    /// start that is already feasible is returned unchanged without a Jacobian.
    #[test]
    fn reaches_the_feasible_set_within_the_box() {
        let settings = FeasibilitySettings {
            target: 1e-10,
            max_iterations: 50,
            max_time: 10.0,
            log: LogTarget::default(),
        };
        let out = restore(&Circle, &[0.1, 0.1, 0.0], &settings);
        assert!(out.reached, "{out:?}");
        let z = &out.z;
        assert!((z[0] * z[0] + z[1] * z[1] - 1.0).abs() <= 1e-10);
        assert!(z[0] - z[1] >= 0.5 - 1e-10);
        assert!(z[1] <= 0.2 && z.iter().all(|v| v.abs() <= 2.0));
        assert!(out.iterations < 30, "{}", out.iterations);
        let again = restore(&Circle, z, &settings);
        assert_eq!(again.iterations, 0);
        assert_eq!(&again.z, z);
    }

    /// An infeasible problem ends at a stationary point of the violation, not reached.
    #[test]
    fn reports_an_unreachable_target() {
        struct Far;
        impl Nlp for Far {
            fn dims(&self) -> Dims {
                Dims {
                    n: 1,
                    m: 1,
                    jac_nnz: 1,
                    hess_nnz: 0,
                }
            }
            fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
                xl[0] = -1.0;
                xu[0] = 1.0;
                cl[0] = 2.0;
                cu[0] = 2.0;
            }
            fn start(&self, x: &mut [f64]) {
                x[0] = 0.0;
            }
            fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
                rows[0] = 0;
                cols[0] = 0;
            }
            fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
                *f = 0.0;
                c[0] = x[0];
                Ok(())
            }
            fn eval_derivatives(
                &self,
                _: &[f64],
                g: &mut [f64],
                jac: &mut [f64],
            ) -> Result<(), EvalError> {
                g[0] = 0.0;
                jac[0] = 1.0;
                Ok(())
            }
        }
        let settings = FeasibilitySettings {
            target: 1e-8,
            max_iterations: 20,
            max_time: 10.0,
            log: LogTarget::default(),
        };
        let out = restore(&Far, &[0.0], &settings);
        assert!(!out.reached);
        assert!((out.z[0] - 1.0).abs() < 1e-12);
        assert!((out.max_violation - 1.0).abs() < 1e-12);
    }
}
