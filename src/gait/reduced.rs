//! The reduced-gradient spacetime problem (seed §3.5, eq. 3.22) as an [`Nlp`]:
//! ```text
//!   min_p  Σₐ ∫₀ᵀ Fₐ(t; p)² dt    s.t.   lower ≤ C(x(t_i; p)) ≤ upper   (pose constraints)
//!   bounds: knot values within the actuator's force bounds, slopes free
//! ```
//! where `p` are the Hermite spline parameters of the actuator forces ([`crate::gait::spline`])
//! and `x(t; p)` is the RK4 simulation from the fixed initial state. `eval` simulates only to the
//! last constraint time. `eval_derivatives` differentiates the whole rollout exactly by forward
//! sensitivities of the RK4 map with analytical ABA derivatives (`reduced/sensitivity.rs`; ≈ 6× one
//! simulation on the Luxo leap). The reference oracle, and the fallback for floating bases, is
//! forward dual numbers (`DualSVec64<8>`): the columns are split into chunks of 8 directions, ordered by
//! knot so that a chunk of late knots runs a short rollout — a knot whose support starts at or
//! after a constraint's time cannot affect it, so that Jacobian entry is structurally zero and
//! absent from the pattern. Chunks run in parallel (rayon); each chunk's result is independent
//! of scheduling. The objective and its gradient are closed-form and need no simulation.

use nalgebra::DMatrix;
use num_dual::DualSVec64;
use rayon::prelude::*;

use super::sim::{Controls, SimError, Simulator, State};
use super::spatial::Real;
use super::spec::Problem;
use super::spline::{KnotGrid, SplineControls};
use crate::solver::{Dims, EvalError, Nlp};

mod sensitivity;

/// Directions propagated per dual rollout.
pub const CHUNK: usize = 8;

/// The reduced-gradient NLP of one gait problem.
#[derive(Debug, Clone)]
pub struct Reduced<'p> {
    problem: &'p Problem,
    grid: KnotGrid,
    /// Distinct sample steps, ascending.
    steps: Vec<usize>,
    /// For each constraint row, its index into `steps`.
    row_sample: Vec<usize>,
    /// Jacobian pattern, (row, col), row-major.
    pattern: Vec<(usize, usize)>,
    /// Position of (row, col) in `pattern`, dense m×n.
    slot: Vec<Option<usize>>,
    /// Column chunks for dual rollouts.
    chunks: Vec<Vec<usize>>,
}

impl<'p> Reduced<'p> {
    /// Builds the NLP; the problem's constraints must be sorted by time (the loader does this).
    pub fn new(problem: &'p Problem) -> Self {
        let grid = KnotGrid {
            knots: problem.knots,
            horizon: problem.horizon,
        };
        let mut steps: Vec<usize> = problem.constraints.iter().map(|c| c.step).collect();
        steps.dedup();
        let row_sample = problem
            .constraints
            .iter()
            .map(|c| steps.binary_search(&c.step).unwrap_or(0))
            .collect();
        let n = problem.model.actuators.len() * grid.per_actuator();
        let m = problem.constraints.len();
        let mut pattern = Vec::new();
        let mut slot = vec![None; m * n];
        for (r, c) in problem.constraints.iter().enumerate() {
            for j in 0..n {
                if Self::affects(&grid, j, c.time) {
                    slot[r * n + j] = Some(pattern.len());
                    pattern.push((r, j));
                }
            }
        }
        let mut cols: Vec<usize> = (0..n).collect();
        cols.sort_by_key(|&j| (grid.knot_of(j % grid.per_actuator()), j));
        let chunks = cols.chunks(CHUNK).map(|c| c.to_vec()).collect();
        Reduced {
            problem,
            grid,
            steps,
            row_sample,
            pattern,
            slot,
            chunks,
        }
    }

    /// Whether parameter `j` can influence the motion before time `t` (s): knot `k`'s basis
    /// functions vanish on `[0, t_{k−1}]`.
    fn affects(grid: &KnotGrid, j: usize, t: f64) -> bool {
        let k = grid.knot_of(j % grid.per_actuator());
        k == 0 || grid.time(k - 1) < t
    }

    /// The knot grid.
    pub fn grid(&self) -> KnotGrid {
        self.grid
    }

    /// Simulates with parameters `x` (scalar type `T`) up to `last` samples and writes the
    /// constraint rows whose sample is among them via `write(row, value)`.
    fn simulate<T: Real>(
        &self,
        x: Vec<T>,
        last: usize,
        mut write: impl FnMut(usize, &T),
    ) -> Result<(), SimError> {
        let p = self.problem;
        let m = &p.model;
        let controls = SplineControls {
            grid: self.grid,
            params: x,
        };
        let mut state = State {
            q: p.initial.q.iter().map(|&z| T::from(z)).collect(),
            v: p.initial.v.iter().map(|&z| T::from(z)).collect(),
        };
        let mut sim = Simulator::<T>::new(m);
        let rows = &self.row_sample;
        sim.rollout(
            &mut state,
            p.dt,
            &self.steps[..last],
            &controls,
            |k, s, sim| {
                for (r, c) in p.constraints.iter().enumerate() {
                    if rows[r] == k {
                        write(r, &c.quantity.value(m, s, &sim.dynamics));
                    }
                }
            },
        )
    }

    /// Jacobian values (pattern order) by propagating parameter directions: chunks of
    /// [`CHUNK`] parameters seeded as dual directions through whole rollouts, in parallel.
    pub fn jacobian_by_parameter_duals(&self, x: &[f64], jac: &mut [f64]) -> Result<(), SimError> {
        let n = x.len();
        let results: Vec<Result<Vec<(usize, f64)>, SimError>> = self
            .chunks
            .par_iter()
            .map(|cols| {
                // Rows this chunk can affect; simulate up to the last of their samples.
                let last = self
                    .problem
                    .constraints
                    .iter()
                    .enumerate()
                    .filter(|(r, _)| cols.iter().any(|&j| self.slot[r * n + j].is_some()))
                    .map(|(r, _)| self.row_sample[r] + 1)
                    .max()
                    .unwrap_or(0);
                let mut out = Vec::new();
                if last == 0 {
                    return Ok(out);
                }
                let mut params: Vec<DualSVec64<CHUNK>> =
                    x.iter().map(|&z| DualSVec64::from_re(z)).collect();
                for (d, &j) in cols.iter().enumerate() {
                    params[j] = params[j].derivative(d);
                }
                self.simulate(params, last, |r, v| {
                    for (d, &j) in cols.iter().enumerate() {
                        if let Some(s) = self.slot[r * n + j] {
                            let eps = v.eps.0.as_ref().map_or(0.0, |e| e[d]);
                            out.push((s, eps));
                        }
                    }
                })?;
                Ok(out)
            })
            .collect();
        for r in results {
            for (s, v) in r? {
                jac[s] = v;
            }
        }
        Ok(())
    }

    /// Jacobian values (pattern order) by discrete tangent propagation: each RK4 step is
    /// differentiated once with `N ≥ nx + 3·na` dual directions (the state, and the actuator
    /// forces at the step's three distinct stage times), giving `Φ = ∂x_{n+1}/∂x_n` and
    /// `G_s = ∂x_{n+1}/∂u_s`; the sensitivities `S = dx/dp` follow
    /// `S_{n+1} = Φ·S_n + Σ_s G_s·W_s` with `W_s` the spline weights at stage time `s`, and a
    /// constraint row is `∂C/∂x · S` at its sample. The cost per step does not grow with the
    /// number of parameters (apart from the small product); on the Luxo leap it takes about as
    /// long as the chunked method on one thread (BENCHMARKS.md), which also runs its chunks in
    /// parallel, so this is the independent cross-check rather than the default.
    pub fn jacobian_by_tangents<const N: usize>(
        &self,
        x: &[f64],
        jac: &mut [f64],
    ) -> Result<(), SimError> {
        type D<const N: usize> = DualSVec64<N>;
        let p = self.problem;
        let m = &p.model;
        let (nq, nv, na) = (m.nq, m.nv, m.actuators.len());
        let nx = nq + nv;
        assert!(nx + 3 * na <= N, "too few dual directions");
        let n_par = x.len();
        let block = self.grid.per_actuator();
        let h = p.dt;
        let spline = SplineControls {
            grid: self.grid,
            params: x.to_vec(),
        };
        let lift = |s: &State<f64>| State {
            q: s.q
                .iter()
                .enumerate()
                .map(|(i, &z)| D::<N>::from_re(z).derivative(i))
                .collect(),
            v: s.v
                .iter()
                .enumerate()
                .map(|(i, &z)| D::<N>::from_re(z).derivative(nq + i))
                .collect(),
        };
        let eps = |z: &D<N>, d: usize| z.eps.0.as_ref().map_or(0.0, |e| e[d]);
        let mut sens = DMatrix::<f64>::zeros(nx, n_par);
        let mut next = DMatrix::<f64>::zeros(nx, n_par);
        let mut phi = DMatrix::<f64>::zeros(nx, nx);
        let mut state = p.initial.clone();
        let mut sim = Simulator::<D<N>>::new(m);
        let mut n = 0;
        for (k, &target) in self.steps.iter().enumerate() {
            while n < target {
                let t0 = n as f64 * h;
                let mut xd = lift(&state);
                let controls = |t: f64, out: &mut [D<N>]| {
                    let mut f = vec![0.0; out.len()];
                    spline.forces(t, &mut f);
                    let stage = ((t - t0) / h * 2.0).round() as usize;
                    for (a, (o, fa)) in out.iter_mut().zip(&f).enumerate() {
                        *o = D::<N>::from_re(*fa).derivative(nx + stage * na + a);
                    }
                };
                sim.step(t0, h, &mut xd, &controls)?;
                let outs: Vec<&D<N>> = xd.q.iter().chain(&xd.v).collect();
                for (i, z) in outs.iter().enumerate() {
                    for j in 0..nx {
                        phi[(i, j)] = eps(z, j);
                    }
                }
                next.gemm(1.0, &phi, &sens, 0.0);
                for stage in 0..3 {
                    let (idx, w) = self.grid.weights(t0 + 0.5 * h * stage as f64);
                    for a in 0..na {
                        let d = nx + stage * na + a;
                        for (i, z) in outs.iter().enumerate() {
                            let g = eps(z, d);
                            for (c, wc) in idx.iter().zip(&w) {
                                next[(i, a * block + c)] += g * wc;
                            }
                        }
                    }
                }
                std::mem::swap(&mut sens, &mut next);
                for (dst, z) in state.q.iter_mut().chain(state.v.iter_mut()).zip(&outs) {
                    *dst = z.re;
                }
                n += 1;
            }
            let xd = lift(&state);
            sim.observe(&xd);
            for (r, c) in p.constraints.iter().enumerate() {
                if self.row_sample[r] != k {
                    continue;
                }
                let v = c.quantity.value(m, &xd, &sim.dynamics);
                for j in 0..n_par {
                    if let Some(slot) = self.slot[r * n_par + j] {
                        jac[slot] = (0..nx).map(|i| eps(&v, i) * sens[(i, j)]).sum();
                    }
                }
            }
        }
        Ok(())
    }

    fn objective(&self, x: &[f64], grad: Option<&mut [f64]>) -> f64 {
        let block = self.grid.per_actuator();
        let mut f = 0.0;
        match grad {
            Some(g) => {
                g.fill(0.0);
                for (xa, ga) in x.chunks(block).zip(g.chunks_mut(block)) {
                    f += self.grid.integral_of_square(xa, Some(ga));
                }
            }
            None => {
                for xa in x.chunks(block) {
                    f += self.grid.integral_of_square(xa, None);
                }
            }
        }
        f
    }
}

fn domain(e: SimError) -> EvalError {
    EvalError::Domain(e.to_string())
}

impl Nlp for Reduced<'_> {
    fn dims(&self) -> Dims {
        Dims {
            n: self.problem.model.actuators.len() * self.grid.per_actuator(),
            m: self.problem.constraints.len(),
            jac_nnz: self.pattern.len(),
            hess_nnz: 0,
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        let (k, block) = (self.grid.knots, self.grid.per_actuator());
        for (a, act) in self.problem.model.actuators.iter().enumerate() {
            for j in 0..block {
                let (lo, hi) = if j < k {
                    (act.bounds[0], act.bounds[1])
                } else {
                    (f64::NEG_INFINITY, f64::INFINITY)
                };
                xl[a * block + j] = lo;
                xu[a * block + j] = hi;
            }
        }
        for (r, c) in self.problem.constraints.iter().enumerate() {
            cl[r] = c.lower;
            cu[r] = c.upper;
        }
    }

    fn start(&self, x: &mut [f64]) {
        let (k, block) = (self.grid.knots, self.grid.per_actuator());
        x.fill(0.0);
        for (a, s) in self.problem.start.iter().enumerate() {
            x[a * block..a * block + k].copy_from_slice(s);
        }
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for (i, &(r, c)) in self.pattern.iter().enumerate() {
            rows[i] = r;
            cols[i] = c;
        }
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = self.objective(x, None);
        self.simulate(x.to_vec(), self.steps.len(), |r, v| c[r] = *v)
            .map_err(domain)?;
        if f.is_finite() && c.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(EvalError::Domain(
                "non-finite objective or constraint".into(),
            ))
        }
    }

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        self.objective(x, Some(grad));
        jac.fill(0.0);
        if !self.jacobian_by_sensitivities(x, jac).map_err(domain)? {
            self.jacobian_by_parameter_duals(x, jac).map_err(domain)?;
        }
        if grad.iter().chain(jac.iter()).all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(EvalError::Domain("non-finite derivatives".into()))
        }
    }

    fn constraint_name(&self, row: usize) -> String {
        self.problem.constraints[row].name.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use std::path::PathBuf;

    /// A problem file with its key times (and horizon) scaled by `factor`.
    pub(super) fn shortened(name: &str, factor: f64) -> Problem {
        let path =
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(format!("problems/gait/{name}.toml"));
        let mut p = crate::gait::load(&path).unwrap();
        p.horizon *= factor;
        for c in &mut p.constraints {
            c.time *= factor;
            c.step = (c.time / p.dt).round() as usize;
        }
        p
    }

    #[test]
    fn exact_derivatives_match_central_differences() {
        for (name, factor) in [("luxo_leap", 0.1), ("pogo_jump", 0.1), ("biped_hop", 0.05)] {
            let p = shortened(name, factor);
            let nlp = Reduced::new(&p);
            let d = nlp.dims();
            let mut rng = ChaCha8Rng::seed_from_u64(3);
            let mut x = vec![0.0; d.n];
            nlp.start(&mut x);
            let (mut xl, mut xu, mut cl, mut cu) = (
                vec![0.0; d.n],
                vec![0.0; d.n],
                vec![0.0; d.m],
                vec![0.0; d.m],
            );
            nlp.bounds(&mut xl, &mut xu, &mut cl, &mut cu);
            for j in 0..d.n {
                // Random forces within a third of the bounds; random slopes.
                let span = if xl[j].is_finite() {
                    (xu[j] - xl[j]) / 6.0
                } else {
                    20.0
                };
                x[j] = rng.random_range(-span..span);
            }
            let mut grad = vec![0.0; d.n];
            let mut jac = vec![0.0; d.jac_nnz];
            nlp.eval_derivatives(&x, &mut grad, &mut jac).unwrap();
            // Two exact methods (analytical sensitivities, dual tangent propagation) agree.
            let mut by_tangents = vec![0.0; d.jac_nnz];
            nlp.jacobian_by_tangents::<48>(&x, &mut by_tangents)
                .unwrap();
            let gap = jac
                .iter()
                .zip(&by_tangents)
                .map(|(a, b)| (a - b).abs() / a.abs().max(1.0))
                .fold(0.0, f64::max);
            assert!(gap < 1e-9, "{name}: parameter duals vs tangents {gap}");
            let (mut rows, mut cols) = (vec![0; d.jac_nnz], vec![0; d.jac_nnz]);
            nlp.jacobian_structure(&mut rows, &mut cols);
            let mut dense = vec![0.0; d.m * d.n];
            for k in 0..d.jac_nnz {
                dense[rows[k] * d.n + cols[k]] += jac[k];
            }
            let (mut worst, mut worst_g): (f64, f64) = (0.0, 0.0);
            for j in 0..d.n {
                let h = 1e-6 * x[j].abs().max(1.0);
                let (mut xp, mut xm) = (x.clone(), x.clone());
                xp[j] += h;
                xm[j] -= h;
                let (mut fp, mut fm, mut cp, mut cm) = (0.0, 0.0, vec![0.0; d.m], vec![0.0; d.m]);
                nlp.eval(&xp, &mut fp, &mut cp).unwrap();
                nlp.eval(&xm, &mut fm, &mut cm).unwrap();
                let g = (fp - fm) / (2.0 * h);
                worst_g = worst_g.max((g - grad[j]).abs() / grad[j].abs().max(1.0));
                for r in 0..d.m {
                    let fd = (cp[r] - cm[r]) / (2.0 * h);
                    let ad = dense[r * d.n + j];
                    if nlp.slot[r * d.n + j].is_none() {
                        assert_eq!(
                            fd, 0.0,
                            "{name}: structural zero ({r}, {j}) has a difference {fd}"
                        );
                    }
                    worst = worst.max((fd - ad).abs() / ad.abs().max(1.0));
                }
            }
            println!(
                "{name}: n = {}, m = {}, nnz = {}, max relative |exact − central| = {worst:.2e}, gradient {worst_g:.2e}",
                d.n, d.m, d.jac_nnz
            );
            assert!(worst < 1e-5, "{name}: {worst}");
            assert!(worst_g < 1e-6, "{name}: {worst_g}");
        }
    }

    #[test]
    fn check_run_passes_on_a_short_pogo_jump() {
        let p = shortened("pogo_jump", 0.2);
        let opts = crate::run::RunOptions {
            check: true,
            ..Default::default()
        };
        let out = crate::gait::run(&p, &opts).unwrap();
        assert_eq!(out.check_passed, Some(true), "{:?}", out.summary.figures);
        assert_eq!(out.summary.status, "Checked");
        // The shipped start (no force) leaves the pogo on the ground: the jump is violated by
        // about 0.5 m.
        assert!(
            out.summary.max_violation > 0.4,
            "{}",
            out.summary.max_violation
        );
    }
}
