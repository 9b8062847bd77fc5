//! The reduced-gradient problem as the solver sees it: [`Reduced`] with scaled variables, a
//! scaled objective and spline bounds that keep the forces within the actuator limits at every
//! instant, not only at the knots.
//!
//! **Force bounds between knots.** On a segment of length `h` the Hermite force is
//! `F(u) = h₀₀(u)·y₀ + h₀₁(u)·y₁ + h·(h₁₀(u)·s₀ + h₁₁(u)·s₁)` with `h₀₀ + h₀₁ = 1`,
//! `h₀₀, h₀₁ ≥ 0` and `|h₁₀(u)| + |h₁₁(u)| = u(1 − u)² + u²(1 − u) = u(1 − u) ≤ 1/4` on
//! `[0, 1]`. With knot values in `[lo + δ, hi − δ]` and slopes `|s| ≤ S`, the first part stays in
//! `[lo + δ, hi − δ]` and the second is at most `h·S/4` in size, so `S = 4δ/h` keeps
//! `F(t) ∈ [lo, hi]` for all `t`, tightly (`y₀ = y₁ = hi − δ`, `s₀ = S`, `s₁ = −S` reach `hi` at
//! mid-segment).
//! `δ = margin·(hi − lo)/2` (`[trials] slope_margin`). Box bounds only: no extra constraints.
//! For a servo actuator the spline is its set-point offset and `[lo, hi]` the joint's limits
//! less its rest angle ([`crate::gait::character::Actuator::control_range`]); the servo law
//! itself keeps the force within its bounds.
//!
//! **Scaling.** Variable `z_j = x_j / σ_j` with `σ = (hi − lo)/2` for knot values and `σ = S`
//! for slopes, so every variable ranges over about `[−1, 1]`; the objective `∫ΣF²dt` (N²·s) is
//! divided by `Σₐ fₐ²·T`, `fₐ` half the actuator's force range. Constraints keep their units (m, rad, m/s). With multiple shooting
//! the segment start states follow the spline parameters as variables, unscaled (m, rad, m/s,
//! rad/s) and unbounded; they start at the rollout of the start forces.

use super::reduced::Reduced;
use super::spec::Problem;
use crate::solver::{Dims, EvalError, Nlp};

/// The scaled, spline-bounded reduced-gradient NLP (module header).
#[derive(Debug, Clone)]
pub struct Formulation<'p> {
    /// The NLP solved: `[controls] shooting_segments` segments.
    inner: Reduced<'p>,
    /// Single shooting: the motion the spline parameters actually produce.
    single: Reduced<'p>,
    /// Physical value of one scaled unit per variable (N, N·m, N/s or N·m/s).
    scale: Vec<f64>,
    /// Physical bounds per variable.
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// Divides the objective (N²·s).
    objective_scale: f64,
    /// Whether the objective is the effort (else zero: a feasibility problem).
    effort: bool,
    /// Column of each Jacobian entry.
    columns: Vec<usize>,
    /// Hand-made start in physical units (clamped into the bounds).
    start: Vec<f64>,
}

impl<'p> Formulation<'p> {
    /// Builds the formulation of `problem`.
    pub fn new(problem: &'p Problem) -> Self {
        let inner = Reduced::new(problem);
        let single = Reduced::with_segments(problem, 1);
        let d = inner.dims();
        let grid = inner.grid();
        let (k, block) = (grid.knots, grid.per_actuator());
        let margin = problem.trials.slope_margin;
        let (mut scale, mut lower, mut upper) = (
            vec![1.0; d.n],
            vec![f64::NEG_INFINITY; d.n],
            vec![f64::INFINITY; d.n],
        );
        let mut objective_scale = 0.0;
        for (a, act) in problem.model.actuators.iter().enumerate() {
            let [lo, hi] = act.control_range();
            let half = 0.5 * (hi - lo);
            let delta = margin * half;
            let slope = 4.0 * delta / grid.spacing();
            let force = 0.5 * (act.bounds[1] - act.bounds[0]);
            objective_scale += force * force * grid.horizon;
            for j in 0..block {
                let i = a * block + j;
                if j < k {
                    (scale[i], lower[i], upper[i]) = (half, lo + delta, hi - delta);
                } else {
                    (scale[i], lower[i], upper[i]) = (slope, -slope, slope);
                }
            }
        }
        // State variables (initial and segment start states): the inner box, unscaled.
        let crate::solver::Bounds { xl, xu, .. } = crate::solver::Bounds::of(&inner);
        let spline = problem.spline_parameters();
        lower[spline..].copy_from_slice(&xl[spline..]);
        upper[spline..].copy_from_slice(&xu[spline..]);
        let (mut rows, mut columns) = (vec![0; d.jac_nnz], vec![0; d.jac_nnz]);
        inner.jacobian_structure(&mut rows, &mut columns);
        let mut start = vec![0.0; d.n];
        inner.start(&mut start);
        for (x, (lo, hi)) in start.iter_mut().zip(lower.iter().zip(&upper)) {
            *x = x.clamp(*lo, *hi);
        }
        inner.fill_states(&mut start);
        Formulation {
            inner,
            single,
            scale,
            lower,
            upper,
            objective_scale,
            effort: true,
            columns,
            start,
        }
    }

    /// The same problem with a zero objective: any point meeting the constraints is optimal,
    /// and the SQP's steps are the least changes (in its quasi-Newton metric) that meet their
    /// linearization.
    pub fn without_effort(mut self) -> Self {
        self.effort = false;
        self
    }

    /// The same problem starting from `x` (physical units), clamped into the bounds: all
    /// variables, or the spline parameters alone, the segment start states then taken from
    /// their rollout.
    pub fn starting_at(&self, x: &[f64]) -> Self {
        let mut out = self.clone();
        for (j, s) in out.start.iter_mut().enumerate().take(x.len()) {
            *s = x[j].clamp(self.lower[j], self.upper[j]);
        }
        if x.len() < out.start.len() {
            self.inner.fill_states(&mut out.start);
        }
        out
    }

    /// The unscaled single-shooting NLP: its constraints are those of the motion the spline
    /// parameters produce (the first [`Reduced::parameters`] variables of any formulation).
    pub fn reduced(&self) -> &Reduced<'p> {
        &self.single
    }

    /// The unscaled NLP solved (multiple shooting when the problem asks for it).
    pub fn shooting(&self) -> &Reduced<'p> {
        &self.inner
    }

    /// Physical spline parameters from scaled variables.
    pub fn physical(&self, z: &[f64]) -> Vec<f64> {
        z.iter().zip(&self.scale).map(|(z, s)| z * s).collect()
    }

    /// Scaled variables from physical spline parameters.
    pub fn scaled(&self, x: &[f64]) -> Vec<f64> {
        x.iter().zip(&self.scale).map(|(x, s)| x / s).collect()
    }

    /// Physical bounds `(lower, upper)` of the variables (spline parameters first).
    pub fn physical_bounds(&self) -> (&[f64], &[f64]) {
        (&self.lower, &self.upper)
    }

    /// The hand-made start in physical units, within the bounds.
    pub fn hand_made_start(&self) -> &[f64] {
        &self.start
    }

    /// The objective's divisor (N²·s): scaled objective = `∫ΣF²dt` / this.
    pub fn objective_scale(&self) -> f64 {
        self.objective_scale
    }
}

impl Nlp for Formulation<'_> {
    fn dims(&self) -> Dims {
        self.inner.dims()
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        let d = self.inner.dims();
        let (mut pl, mut pu) = (vec![0.0; d.n], vec![0.0; d.n]);
        self.inner.bounds(&mut pl, &mut pu, cl, cu);
        for j in 0..d.n {
            xl[j] = self.lower[j] / self.scale[j];
            xu[j] = self.upper[j] / self.scale[j];
        }
    }

    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.scaled(&self.start));
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        self.inner.jacobian_structure(rows, cols);
    }

    fn eval(&self, z: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        self.inner.eval(&self.physical(z), f, c)?;
        *f = if self.effort {
            *f / self.objective_scale
        } else {
            0.0
        };
        Ok(())
    }

    fn eval_derivatives(
        &self,
        z: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        self.inner.eval_derivatives(&self.physical(z), grad, jac)?;
        let weight = if self.effort { 1.0 } else { 0.0 };
        for (g, s) in grad.iter_mut().zip(&self.scale) {
            *g *= weight * s / self.objective_scale;
        }
        for (v, &j) in jac.iter_mut().zip(&self.columns) {
            *v *= self.scale[j];
        }
        Ok(())
    }

    fn constraint_name(&self, row: usize) -> String {
        self.inner.constraint_name(row)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gait::sim::Controls;
    use crate::gait::spline::SplineControls;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::path::PathBuf;

    fn load(name: &str) -> Problem {
        let path =
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("problems/gait/{name}.toml"));
        crate::gait::load(&path).unwrap()
    }

    /// Random parameters anywhere in the box, including its corners, never give forces outside
    /// the actuator bounds at any time, and the corners come within 1% of reaching them.
    #[test]
    fn box_bounds_keep_forces_within_limits_between_knots() {
        // Force controls (the shipped luxo_leap has servos, whose controls are set points).
        let p = load("luxo_leap_soft");
        let f = Formulation::new(&p);
        let d = f.dims();
        let (lo, hi) = f.physical_bounds();
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let na = p.model.actuators.len();
        let mut reach = vec![0.0f64; na];
        for trial in 0..200 {
            let x: Vec<f64> = (0..d.n)
                .map(|j| {
                    if trial % 2 == 0 {
                        if rng.random::<bool>() { hi[j] } else { lo[j] }
                    } else {
                        rng.random_range(lo[j]..hi[j])
                    }
                })
                .collect();
            let controls = SplineControls {
                grid: f.reduced().grid(),
                params: x,
            };
            let mut out = vec![0.0; na];
            for i in 0..=2000 {
                controls.forces(p.horizon * i as f64 / 2000.0, &mut out);
                for (a, act) in p.model.actuators.iter().enumerate() {
                    let [blo, bhi] = act.bounds;
                    assert!(
                        out[a] >= blo - 1e-9 && out[a] <= bhi + 1e-9,
                        "actuator {a}: {} outside [{blo}, {bhi}]",
                        out[a]
                    );
                    reach[a] = reach[a].max(out[a].abs() / bhi.abs().max(blo.abs()));
                }
            }
        }
        for r in reach {
            assert!(r > 0.99, "bounds not tight: {r}");
        }
    }

    /// The scaled derivatives are the chain rule applied to the unscaled ones.
    #[test]
    fn scaled_derivatives_match_central_differences() {
        let mut p = load("pogo_jump");
        p.horizon *= 0.1;
        for c in &mut p.constraints {
            c.time *= 0.1;
            c.step = (c.time / p.dt).round() as usize;
        }
        let f = Formulation::new(&p);
        let d = f.dims();
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let z: Vec<f64> = (0..d.n).map(|_| rng.random_range(-0.5..0.5)).collect();
        let (mut g, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
        f.eval_derivatives(&z, &mut g, &mut jac).unwrap();
        let (mut rows, mut cols) = (vec![0; d.jac_nnz], vec![0; d.jac_nnz]);
        f.jacobian_structure(&mut rows, &mut cols);
        for j in 0..d.n {
            let e = 1e-6;
            let (mut zp, mut zm) = (z.clone(), z.clone());
            zp[j] += e;
            zm[j] -= e;
            let (mut fp, mut fm, mut cp, mut cm) = (0.0, 0.0, vec![0.0; d.m], vec![0.0; d.m]);
            f.eval(&zp, &mut fp, &mut cp).unwrap();
            f.eval(&zm, &mut fm, &mut cm).unwrap();
            let gd = (fp - fm) / (2.0 * e);
            assert!(
                (gd - g[j]).abs() < 1e-6 * g[j].abs().max(1.0),
                "{j}: {gd} vs {}",
                g[j]
            );
            for k in (0..d.jac_nnz).filter(|&k| cols[k] == j) {
                let fd = (cp[rows[k]] - cm[rows[k]]) / (2.0 * e);
                assert!(
                    (fd - jac[k]).abs() < 1e-5 * jac[k].abs().max(1.0),
                    "({}, {j}): {fd} vs {}",
                    rows[k],
                    jac[k]
                );
            }
        }
    }
}
