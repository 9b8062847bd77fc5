//! The reduced-gradient spacetime problem (seed §3.5, eq. 3.22) as an [`Nlp`], by single or
//! multiple shooting:
//! ```text
//!   min_{p, s₁…s_{S−1}}  Σₐ ∫₀ᵀ Fₐ(t; p)² dt
//!   s.t.  lower ≤ C(x(t_i; p, s_k(i))) ≤ upper        (pose constraints)
//!         x(b_k; p, s_{k−1}) − s_k = 0,  k = 1…S−1      (continuity)
//!   bounds: knot values within the actuator's force bounds, slopes and states free
//! ```
//! where `p` are the Hermite spline parameters of the actuator forces ([`crate::gait::spline`]).
//! The interval `[0, t_last]` up to the last constraint time is split into `S` segments at the
//! RK4 steps `b_k = round(k·N/S)` (`N` = steps to `t_last`; `[controls] shooting_segments`) or
//! at given times (`[controls] shooting_times`, `b_k = t_k/dt`).
//! Segment `k` is simulated by RK4 from its start state `s_k = (q, v)` at `b_k` under the same
//! force splines (absolute time); `s₀` is the problem's initial state, `s₁…s_{S−1}` are
//! variables, ordered after `p`, `nq + nv` each. With `[controls] initial_state` (seed §3.7:
//! the seed optimized the initial configuration too) `s₀` is a variable as well, right after
//! `p` and before `s₁`, boxed around the file's initial state; its Jacobian columns come from
//! the same forward sensitivities, seeded with the identity. The motion parameters
//! ([`Reduced::parameters`]) are `p` and, when free, `s₀`: one rollout of them is the motion. A pose constraint at step `n` reads the segment
//! with `b_k < n ≤ b_{k+1}` (segment 0 also owns `n = 0`). `S = 1` is single shooting: the
//! variables are `p` alone and the arithmetic is that of one rollout. Multiple shooting keeps
//! each segment short, so the constraints depend less violently on the variables across
//! impacts; the segments are independent and run in parallel (rayon; each writes its own rows).
//!
//! `eval` simulates only to the last constraint time. `eval_derivatives` differentiates each
//! segment exactly by forward sensitivities of the RK4 map with analytical ABA derivatives,
//! seeded with the identity for the segment's start state (`reduced/sensitivity.rs`; about 4× one
//! simulation on the Luxo leap). The reference oracle, and the fallback for floating bases, is
//! forward dual numbers (`DualSVec64<8>`): the columns are split into chunks of 8 directions,
//! ordered by knot. A knot's basis vanishes outside `(t_{k−1}, t_{k+1})`, so a row whose segment
//! lies outside that interval cannot depend on it: that Jacobian entry is structurally zero and
//! absent from the pattern. Chunks run in parallel (rayon); each chunk's result is independent
//! of scheduling. With force controls the objective and its gradient are closed-form and need
//! no simulation; with servo actuators ([`crate::gait::character::Servo`]) the splines are
//! set points, the force depends on the state, and the effort `∫₀ᵀ Σ τ² dt` is integrated along
//! the rollout (to the horizon) with the RK4 weights, its gradient propagated with the
//! sensitivities (or the dual numbers) like a constraint row.

use nalgebra::DMatrix;
use num_dual::DualSVec64;
use rayon::prelude::*;

use super::sim::{Controls, SimError, Simulator, State};
use super::spatial::Real;
use super::spec::Problem;
use super::spline::{KnotGrid, SplineControls};
use crate::solver::{Dims, EvalError, Nlp};

mod sensitivity;
#[cfg(test)]
mod shooting_tests;

/// Directions propagated per dual rollout.
pub const CHUNK: usize = 8;

/// The reduced-gradient NLP of one gait problem (module header).
#[derive(Debug, Clone)]
pub struct Reduced<'p> {
    problem: &'p Problem,
    grid: KnotGrid,
    /// Spline parameters (the first variables).
    n_par: usize,
    /// The first segment whose start state is a variable: 0 when the initial state is one
    /// (`[controls] initial_state`), else 1.
    first_state: usize,
    /// State size `nq + nv`.
    nx: usize,
    /// Segment boundaries in RK4 steps, `0 = b₀ < b₁ < … < b_S`.
    boundaries: Vec<usize>,
    /// Per segment, its distinct sample steps, ascending.
    samples: Vec<Vec<usize>>,
    /// For each pose-constraint row, its segment and index into that segment's samples.
    row_sample: Vec<(usize, usize)>,
    /// Jacobian pattern, (row, col), row-major.
    pattern: Vec<(usize, usize)>,
    /// Position of (row, col) in `pattern`, dense m×n.
    slot: Vec<Option<usize>>,
    /// Column chunks for dual rollouts.
    chunks: Vec<Vec<usize>>,
}

impl<'p> Reduced<'p> {
    /// Builds the NLP with the problem's segments (`shooting_times`, else `segments` equal
    /// ones); the problem's constraints must be sorted by time (the loader does this).
    pub fn new(problem: &'p Problem) -> Self {
        if problem.shooting_steps.is_empty() {
            Self::with_segments(problem, problem.segments)
        } else {
            Self::with_boundaries(problem, &problem.shooting_steps)
        }
    }

    /// Builds the NLP with `segments` equal shooting segments (clamped to `1..=` the steps to
    /// the last constraint, so every segment has at least one step).
    pub fn with_segments(problem: &'p Problem, segments: usize) -> Self {
        let last = problem.constraints.last().map_or(0, |c| c.step);
        let s = segments.clamp(1, last.max(1));
        let interior: Vec<usize> = (1..s)
            .map(|k| ((k * last) as f64 / s as f64).round() as usize)
            .collect();
        Self::with_boundaries(problem, &interior)
    }

    /// Builds the NLP with segments split at the RK4 steps `interior` (ascending; steps not
    /// strictly between 0 and the last constraint's step are dropped, as are repeats).
    pub fn with_boundaries(problem: &'p Problem, interior: &[usize]) -> Self {
        let grid = problem.knot_grid();
        let last = problem.constraints.last().map_or(0, |c| c.step);
        let mut boundaries = vec![0];
        for &b in interior {
            if b > *boundaries.last().expect("non-empty") && b < last {
                boundaries.push(b);
            }
        }
        boundaries.push(last.max(1));
        let s = boundaries.len() - 1;
        let first_state = if problem.initial_box.is_some() { 0 } else { 1 };
        let segment_of = |step: usize| (0..s).find(|&k| step <= boundaries[k + 1]).unwrap_or(s - 1);
        let mut samples = vec![Vec::new(); s];
        let row_sample = problem
            .constraints
            .iter()
            .map(|c| {
                let k = segment_of(c.step);
                if samples[k].last() != Some(&c.step) {
                    samples[k].push(c.step);
                }
                (k, samples[k].len() - 1)
            })
            .collect();
        let n_par = problem.model.actuators.len() * grid.per_actuator();
        let nx = problem.model.nq + problem.model.nv;
        let n = n_par + (s - first_state) * nx;
        let m = problem.constraints.len() + (s - 1) * nx;
        let h = problem.dt;
        let mut pattern = Vec::new();
        let mut slot = vec![None; m * n];
        let mut push = |r: usize, j: usize| {
            slot[r * n + j] = Some(pattern.len());
            pattern.push((r, j));
        };
        // Row r depends on the parameters acting in (b_k·h, t] and on its segment's start state.
        let mut rows: Vec<(usize, f64, Option<usize>)> = problem
            .constraints
            .iter()
            .map(|c| (segment_of(c.step), c.time, None))
            .collect();
        let column = |k: usize, i: usize| n_par + (k - first_state) * nx + i;
        for (k, &b) in boundaries.iter().enumerate().take(s).skip(1) {
            for i in 0..nx {
                rows.push((k - 1, b as f64 * h, Some(column(k, i))));
            }
        }
        for (r, &(k, t, own)) in rows.iter().enumerate() {
            let t_lo = boundaries[k] as f64 * h;
            for j in 0..n_par {
                if Self::affects(&grid, j, t_lo, t) {
                    push(r, j);
                }
            }
            let mut cols: Vec<usize> = if k >= first_state {
                (0..nx).map(|i| column(k, i)).collect()
            } else {
                Vec::new()
            };
            cols.extend(own);
            cols.sort_unstable();
            for j in cols {
                push(r, j);
            }
        }
        let mut cols: Vec<usize> = (0..n).collect();
        cols.sort_by_key(|&j| {
            let knot = if j < n_par {
                grid.knot_of(j % grid.per_actuator())
            } else {
                0
            };
            (j >= n_par, knot, j)
        });
        let chunks = cols.chunks(CHUNK).map(|c| c.to_vec()).collect();
        Reduced {
            problem,
            grid,
            n_par,
            first_state,
            nx,
            boundaries,
            samples,
            row_sample,
            pattern,
            slot,
            chunks,
        }
    }

    /// Whether spline parameter `j` can influence the motion on `(t_lo, t]` (s): knot `k`'s
    /// basis functions vanish outside `(t_{k−1}, t_{k+1})` (kept when `t_{k+1}` is within
    /// round-off of `t_lo`).
    fn affects(grid: &KnotGrid, j: usize, t_lo: f64, t: f64) -> bool {
        let k = grid.knot_of(j % grid.per_actuator());
        let starts_before = k == 0 || grid.time(k - 1) < t;
        let ends_after = k + 1 >= grid.knots || grid.time(k + 1) >= t_lo - 1e-9 * grid.spacing();
        starts_before && ends_after
    }

    /// The knot grid.
    pub fn grid(&self) -> KnotGrid {
        self.grid
    }

    /// Number of shooting segments.
    pub fn segments(&self) -> usize {
        self.boundaries.len() - 1
    }

    /// Segment boundaries in RK4 steps, `0 = b₀ < b₁ < … < b_S`.
    pub fn boundaries(&self) -> &[usize] {
        &self.boundaries
    }

    /// Number of motion parameters (the leading variables): the spline parameters, then the
    /// initial state when it is a variable ([`Problem::motion_parameters`]).
    pub fn parameters(&self) -> usize {
        self.n_par + (1 - self.first_state) * self.nx
    }

    /// Number of pose-constraint rows (the leading rows; continuity rows follow).
    fn pose_rows(&self) -> usize {
        self.problem.constraints.len()
    }

    /// Row of continuity component `i` at the start of segment `k ≥ 1`.
    fn continuity_row(&self, k: usize, i: usize) -> usize {
        self.pose_rows() + (k - 1) * self.nx + i
    }

    /// Column of start-state component `i` of segment `k` (`k ≥ 1`, or `k = 0` with the
    /// initial state as a variable).
    fn state_column(&self, k: usize, i: usize) -> usize {
        self.n_par + (k - self.first_state) * self.nx + i
    }

    /// Whether segment `k`'s start state is a variable.
    fn has_state(&self, k: usize) -> bool {
        k >= self.first_state
    }

    /// Start state of segment `k` from the variables `x`: the file's initial state for `k = 0`
    /// unless it is a variable.
    fn start_state<T: Real>(&self, k: usize, x: &[T]) -> State<T> {
        let nq = self.problem.model.nq;
        if !self.has_state(k) {
            let init = &self.problem.initial;
            State {
                q: init.q.iter().map(|&z| T::from(z)).collect(),
                v: init.v.iter().map(|&z| T::from(z)).collect(),
            }
        } else {
            let s = &x[self.state_column(k, 0)..self.state_column(k, 0) + self.nx];
            State {
                q: s[..nq].to_vec(),
                v: s[nq..].to_vec(),
            }
        }
    }

    /// The states at the segment starts `b₁…b_{S−1}` of one rollout of motion parameters `p`
    /// ([`Self::parameters`]) from the initial state, flattened as the state variables
    /// (`(q, v)` per segment).
    pub fn rollout_states(&self, p: &[f64]) -> Result<Vec<f64>, SimError> {
        let h = self.problem.dt;
        let controls = SplineControls {
            grid: self.grid,
            params: p[..self.n_par].to_vec(),
        };
        let mut state = self.start_state(0, p);
        let mut sim =
            Simulator::<f64>::new(&self.problem.model).interruptible(&self.problem.interrupt);
        let mut out = Vec::with_capacity((self.segments() - 1) * self.nx);
        let mut n = 0;
        for &b in &self.boundaries[1..self.segments()] {
            while n < b {
                sim.step(n as f64 * h, h, &mut state, &controls)?;
                n += 1;
            }
            out.extend(state.q.iter().chain(&state.v));
        }
        Ok(out)
    }

    /// Whether the effort depends on the motion (servo actuators): it is then integrated along
    /// the rollout, to the horizon, instead of in closed form from the splines.
    fn effort_by_rollout(&self) -> bool {
        self.problem.model.has_servos()
    }

    /// The RK4 step where the last segment's simulation ends: its last sample, or the
    /// horizon when the effort is integrated along the rollout.
    fn last_step(&self) -> usize {
        let last = *self.boundaries.last().expect("non-empty");
        if self.effort_by_rollout() {
            last.max((self.problem.horizon / self.problem.dt).round() as usize)
        } else {
            last
        }
    }

    /// Simulates segment `k` with variables `x` (scalar type `T`) and writes its rows via
    /// `write(row, value)`: the pose constraints it owns, then the continuity defects
    /// `x(b_{k+1}) − s_{k+1}` unless it is the last segment. Returns the segment's actuator
    /// effort `∫Σ τ² dt` (N²·s; the last segment's to [`Self::last_step`]).
    fn simulate_segment<T: Real>(
        &self,
        k: usize,
        x: &[T],
        mut write: impl FnMut(usize, &T),
    ) -> Result<T, SimError> {
        let p = self.problem;
        let m = &p.model;
        let h = p.dt;
        let controls = SplineControls {
            grid: self.grid,
            params: x[..self.n_par].to_vec(),
        };
        let mut state = self.start_state(k, x);
        let mut sim = Simulator::<T>::new(m).interruptible(&p.interrupt);
        let mut n = self.boundaries[k];
        for (i, &target) in self.samples[k].iter().enumerate() {
            while n < target {
                sim.step(n as f64 * h, h, &mut state, &controls)?;
                n += 1;
            }
            sim.observe(&state);
            for (r, c) in p.constraints.iter().enumerate() {
                if self.row_sample[r] == (k, i) {
                    write(r, &c.quantity.value(m, &state, &sim.dynamics));
                }
            }
        }
        if k + 1 < self.segments() {
            while n < self.boundaries[k + 1] {
                sim.step(n as f64 * h, h, &mut state, &controls)?;
                n += 1;
            }
            let next = self.start_state(k + 1, x);
            let ends = state.q.iter().chain(&state.v);
            for (i, (a, b)) in ends.zip(next.q.iter().chain(&next.v)).enumerate() {
                write(self.continuity_row(k + 1, i), &(*a - *b));
            }
        } else {
            while n < self.last_step() {
                sim.step(n as f64 * h, h, &mut state, &controls)?;
                n += 1;
            }
        }
        Ok(sim.effort)
    }

    /// Whether row `r` belongs to segment `k` (a pose row it samples, or the continuity defect
    /// at its end).
    fn row_in_segment(&self, r: usize, k: usize) -> bool {
        if r < self.pose_rows() {
            self.row_sample[r].0 == k
        } else {
            (r - self.pose_rows()) / self.nx == k
        }
    }

    /// Jacobian values (pattern order) by propagating variable directions: chunks of
    /// [`CHUNK`] variables seeded as dual directions through the segments they affect, in
    /// parallel. When the effort is integrated along the rollout (servos), its gradient is
    /// written into `grad` too (else `grad` is untouched).
    pub fn jacobian_by_parameter_duals(
        &self,
        x: &[f64],
        jac: &mut [f64],
        grad: &mut [f64],
    ) -> Result<(), SimError> {
        let n = x.len();
        let m = self.dims().m;
        let by_rollout = self.effort_by_rollout();
        type Entries = (Vec<(usize, f64)>, Vec<(usize, f64)>);
        let results: Vec<Result<Entries, SimError>> = self
            .chunks
            .par_iter()
            .map(|cols| {
                let mut params: Vec<DualSVec64<CHUNK>> =
                    x.iter().map(|&z| DualSVec64::from_re(z)).collect();
                for (d, &j) in cols.iter().enumerate() {
                    params[j] = params[j].derivative(d);
                }
                let eps = |v: &DualSVec64<CHUNK>, d: usize| v.eps.0.as_ref().map_or(0.0, |e| e[d]);
                let (mut out, mut effort) = (Vec::new(), vec![0.0; cols.len()]);
                for k in 0..self.segments() {
                    let needed = by_rollout
                        || (0..m).any(|r| {
                            self.row_in_segment(r, k)
                                && cols.iter().any(|&j| self.slot[r * n + j].is_some())
                        });
                    if !needed {
                        continue;
                    }
                    let e = self.simulate_segment(k, &params, |r, v| {
                        for (d, &j) in cols.iter().enumerate() {
                            if let Some(s) = self.slot[r * n + j] {
                                out.push((s, eps(v, d)));
                            }
                        }
                    })?;
                    for (d, g) in effort.iter_mut().enumerate() {
                        *g += eps(&e, d);
                    }
                }
                Ok((out, cols.iter().copied().zip(effort).collect()))
            })
            .collect();
        for r in results {
            let (entries, effort) = r?;
            for (s, v) in entries {
                jac[s] = v;
            }
            if by_rollout {
                for (j, g) in effort {
                    grad[j] = g;
                }
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
    /// long as the chunked method on one thread (docs/notes/gait.md), which also runs its chunks in
    /// parallel, so this is the independent cross-check rather than the default. Single
    /// shooting only (one segment).
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
        assert!(
            self.segments() == 1 && !self.has_state(0),
            "tangent propagation covers single shooting from a fixed initial state"
        );
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
        let mut sim = Simulator::<D<N>>::new(m).interruptible(&p.interrupt);
        let mut n = 0;
        for (k, &target) in self.samples[0].iter().enumerate() {
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
                if self.row_sample[r] != (0, k) {
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

    /// The closed-form effort of the force splines and its gradient (module header); zero,
    /// with a zero gradient, when the effort is integrated along the rollout instead (servos).
    fn objective(&self, x: &[f64], grad: Option<&mut [f64]>) -> f64 {
        if self.effort_by_rollout() {
            if let Some(g) = grad {
                g.fill(0.0);
            }
            return 0.0;
        }
        let block = self.grid.per_actuator();
        let x = &x[..self.n_par];
        let mut f = 0.0;
        match grad {
            Some(g) => {
                g.fill(0.0);
                let g = &mut g[..self.n_par];
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
    /// Overwrites the start-state variables of segments `1…S−1` in `x` with the states of the
    /// rollout of its motion parameters (the initial state where that rollout fails).
    pub fn fill_states(&self, x: &mut [f64]) {
        let states = self.rollout_states(x).unwrap_or_else(|_| {
            let init = self.start_state(0, x);
            let one: Vec<f64> = init.q.iter().chain(&init.v).copied().collect();
            one.repeat(self.segments() - 1)
        });
        let c = self.parameters();
        x[c..].copy_from_slice(&states);
    }
}

/// A failed rollout as an evaluation error: a domain error (the solver backs off), or the
/// interrupt's fatal one ([`crate::solver::interrupt`]).
fn domain(e: SimError) -> EvalError {
    if e.interrupted {
        EvalError::Fatal(crate::solver::interrupt::INTERRUPTED.into())
    } else {
        EvalError::Domain(e.to_string())
    }
}

impl Nlp for Reduced<'_> {
    fn dims(&self) -> Dims {
        let extra = (self.segments() - 1) * self.nx;
        Dims {
            n: self.parameters() + extra,
            m: self.pose_rows() + extra,
            jac_nnz: self.pattern.len(),
            hess_nnz: 0,
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        let (k, block) = (self.grid.knots, self.grid.per_actuator());
        xl.fill(f64::NEG_INFINITY);
        xu.fill(f64::INFINITY);
        for (a, act) in self.problem.model.actuators.iter().enumerate() {
            for j in 0..k {
                [xl[a * block + j], xu[a * block + j]] = act.control_range();
            }
        }
        if let Some((lo, hi)) = &self.problem.initial_box {
            let c = self.state_column(0, 0);
            xl[c..c + self.nx].copy_from_slice(lo);
            xu[c..c + self.nx].copy_from_slice(hi);
        }
        cl.fill(0.0);
        cu.fill(0.0);
        for (r, c) in self.problem.constraints.iter().enumerate() {
            cl[r] = c.lower;
            cu[r] = c.upper;
        }
    }

    /// The hand-made forces, slopes zero, the file's initial state (when a variable), and the
    /// segment start states of their rollout (the initial state where that rollout fails).
    fn start(&self, x: &mut [f64]) {
        let (k, block) = (self.grid.knots, self.grid.per_actuator());
        x.fill(0.0);
        for (a, s) in self.problem.start.iter().enumerate() {
            x[a * block..a * block + k].copy_from_slice(s);
        }
        if self.has_state(0) {
            let init = &self.problem.initial;
            let c = self.state_column(0, 0);
            for (xi, v) in x[c..c + self.nx]
                .iter_mut()
                .zip(init.q.iter().chain(&init.v))
            {
                *xi = *v;
            }
        }
        self.fill_states(x);
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for (i, &(r, c)) in self.pattern.iter().enumerate() {
            rows[i] = r;
            cols[i] = c;
        }
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = self.objective(x, None);
        type Part = (Vec<(usize, f64)>, f64);
        let parts: Vec<Result<Part, SimError>> = (0..self.segments())
            .into_par_iter()
            .map(|k| {
                let mut out = Vec::new();
                let effort = self.simulate_segment(k, x, |r, v| out.push((r, *v)))?;
                Ok((out, effort))
            })
            .collect();
        let by_rollout = self.effort_by_rollout();
        for part in parts {
            let (rows, effort) = part.map_err(domain)?;
            for (r, v) in rows {
                c[r] = v;
            }
            if by_rollout {
                *f += effort;
            }
        }
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
        if !self
            .jacobian_by_sensitivities(x, jac, grad)
            .map_err(domain)?
        {
            self.jacobian_by_parameter_duals(x, jac, grad)
                .map_err(domain)?;
        }
        if grad.iter().chain(jac.iter()).all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(EvalError::Domain("non-finite derivatives".into()))
        }
    }

    fn constraint_name(&self, row: usize) -> String {
        match row.checked_sub(self.pose_rows()) {
            None => self.problem.constraints[row].name.clone(),
            Some(i) => {
                let k = i / self.nx + 1;
                format!(
                    "t={:.4} continuity x[{}]",
                    self.boundaries[k] as f64 * self.problem.dt,
                    i % self.nx
                )
            }
        }
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

    /// Largest entry-wise gap between a Jacobian and the dual-number oracle's, relative to the
    /// oracle's entry or, for small entries, to 1e-3 of its largest entry.
    pub(super) fn gap_to_oracle(fast: &[f64], oracle: &[f64]) -> f64 {
        let largest = oracle.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        fast.iter()
            .zip(oracle)
            .map(|(a, b)| (a - b).abs() / b.abs().max(1e-3 * largest))
            .fold(0.0, f64::max)
    }

    /// Central differences `(∂f/∂x_j, ∂c/∂x_j)`, Richardson-extrapolated:
    /// `D = (4·D(h/2) − D(h))/3` with `D(h)` the central difference of step
    /// `h = 1e-6·max(|x_j|, 1)`, which cancels its h² truncation term. On the servo biped
    /// (`biped_hop`) the plain `D(h)` of the effort's worst column converges to the exact value
    /// as h² down to h = 1e-7 (gaps 6.8e-3 / 7.2e-5 / 1.3e-6 at h = 1e-5 / 1e-6 / 1e-7 on an
    /// entry of 83.3), so at 1e-6 its truncation error alone exceeds the 1e-6 tolerance.
    pub(super) fn central_difference(nlp: &Reduced<'_>, x: &[f64], j: usize) -> (f64, Vec<f64>) {
        let h = 1e-6 * x[j].abs().max(1.0);
        let (g1, c1) = plain_central_difference(nlp, x, j, h);
        let (g2, c2) = plain_central_difference(nlp, x, j, 0.5 * h);
        let extrapolate = |coarse: f64, fine: f64| (4.0 * fine - coarse) / 3.0;
        let dc = c1
            .iter()
            .zip(&c2)
            .map(|(&a, &b)| extrapolate(a, b))
            .collect();
        (extrapolate(g1, g2), dc)
    }

    /// `∂f/∂x_j` of the effort by Ridders' step-adaptive extrapolation (Ridders 1982; Press et
    /// al., Numerical Recipes §5.7): central differences at steps `h₀/2ⁱ`,
    /// `h₀ = 1e-5·max(|x_j|, 1)`, i < 12, extrapolated in a Neville tableau; the entry with the
    /// smallest error estimate counts, and the tableau stops when round-off makes it grow. The
    /// servo biped's effort needs it: its worst column's plain difference converges as h² down
    /// to h ≈ 1e-7, while in columns of small gradient (|∂f/∂x_j| ≈ 5e-4…3e-2) the extrapolated
    /// difference at h = 1e-6 is already off by up to 8e-6 absolute where this one is within
    /// 7e-7, so no one fixed step serves every column.
    pub(super) fn ridders_gradient(nlp: &Reduced<'_>, x: &[f64], j: usize) -> f64 {
        let m = nlp.dims().m;
        let effort = |h: f64| {
            let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
            xp[j] += h;
            xm[j] -= h;
            let (mut fp, mut fm, mut c) = (0.0, 0.0, vec![0.0; m]);
            nlp.eval(&xp, &mut fp, &mut c).unwrap();
            nlp.eval(&xm, &mut fm, &mut c).unwrap();
            (fp - fm) / (2.0 * h)
        };
        const STEPS: usize = 12;
        let mut h = 1e-5 * x[j].abs().max(1.0);
        let mut table = [[0.0f64; STEPS]; STEPS];
        table[0][0] = effort(h);
        let (mut best, mut error) = (table[0][0], f64::INFINITY);
        for i in 1..STEPS {
            h *= 0.5;
            table[0][i] = effort(h);
            let mut factor = 4.0;
            for k in 1..=i {
                table[k][i] = (table[k - 1][i] * factor - table[k - 1][i - 1]) / (factor - 1.0);
                factor *= 4.0;
                let change = (table[k][i] - table[k - 1][i])
                    .abs()
                    .max((table[k][i] - table[k - 1][i - 1]).abs());
                if change <= error {
                    error = change;
                    best = table[k][i];
                }
            }
            if (table[i][i] - table[i - 1][i - 1]).abs() >= 2.0 * error {
                break;
            }
        }
        best
    }

    /// Plain central differences `(∂f/∂x_j, ∂c/∂x_j)` with step `h`.
    fn plain_central_difference(nlp: &Reduced<'_>, x: &[f64], j: usize, h: f64) -> (f64, Vec<f64>) {
        let m = nlp.dims().m;
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[j] += h;
        xm[j] -= h;
        let (mut fp, mut fm, mut cp, mut cm) = (0.0, 0.0, vec![0.0; m], vec![0.0; m]);
        nlp.eval(&xp, &mut fp, &mut cp).unwrap();
        nlp.eval(&xm, &mut fm, &mut cm).unwrap();
        let dc = cp
            .iter()
            .zip(&cm)
            .map(|(a, b)| (a - b) / (2.0 * h))
            .collect();
        ((fp - fm) / (2.0 * h), dc)
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
            let crate::solver::Bounds { xl, xu, .. } = crate::solver::Bounds::of(&nlp);
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
                let (_, dc) = central_difference(&nlp, &x, j);
                let g = ridders_gradient(&nlp, &x, j);
                worst_g = worst_g.max((g - grad[j]).abs() / grad[j].abs().max(1.0));
                for r in 0..d.m {
                    let fd = dc[r];
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
        let opts = crate::outcome::RunOptions {
            check: true,
            ..Default::default()
        };
        let out = crate::application::run_problem::<crate::gait::Gait>(
            &crate::gait::GaitProblem::Reduced(Box::new(p)),
            &opts,
        )
        .unwrap();
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

    /// The Luxo NLP with one Jacobian value scaled by `1 + error` (pattern position `slot`).
    struct OneWrongEntry<'a> {
        nlp: Reduced<'a>,
        slot: usize,
        error: f64,
    }

    impl Nlp for OneWrongEntry<'_> {
        crate::solver::forward_nlp!(nlp; dims, bounds, start, jacobian_structure, eval);
        fn eval_derivatives(
            &self,
            x: &[f64],
            grad: &mut [f64],
            jac: &mut [f64],
        ) -> Result<(), EvalError> {
            self.nlp.eval_derivatives(x, grad, jac)?;
            jac[self.slot] *= 1.0 + self.error;
            Ok(())
        }
    }

    /// `--check`'s comparison passes on the exact Jacobian of a short Luxo leap at random forces
    /// and fails, naming the entry, when one entry is off by 1e-4 relative (ten times the
    /// tolerance).
    #[test]
    fn check_catches_one_wrong_jacobian_entry() {
        let p = shortened("luxo_leap", 0.2);
        let nlp = Reduced::new(&p);
        let d = nlp.dims();
        let mut x = vec![0.0; d.n];
        nlp.start(&mut x);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for (a, v) in x.iter_mut().take(nlp.parameters()).enumerate() {
            *v = rng.random_range(-3.0..3.0) * if a % 2 == 0 { 1.0 } else { 0.2 };
        }
        let (mut grad, mut jac) = (vec![0.0; d.n], vec![0.0; d.jac_nnz]);
        nlp.eval_derivatives(&x, &mut grad, &mut jac).unwrap();
        // The largest entry, so the relative error is 1e-4 whatever its size.
        let slot = (0..d.jac_nnz)
            .max_by(|&a, &b| jac[a].abs().total_cmp(&jac[b].abs()))
            .unwrap();
        let options = crate::gait::check_options();
        for error in [0.0, 1e-4] {
            let broken = OneWrongEntry {
                nlp: nlp.clone(),
                slot,
                error,
            };
            let report =
                crate::solver::derivatives::check_derivatives(&broken, &x, &options).unwrap();
            if error == 0.0 {
                assert!(report.passed(), "{report}");
            } else {
                assert!(!report.passed(), "{report}");
                let (rows, cols) = (&mut vec![0; d.jac_nnz], &mut vec![0; d.jac_nnz]);
                nlp.jacobian_structure(rows, cols);
                let worst = &report.worst_per_function[0];
                assert_eq!(
                    (worst.row, worst.col),
                    (Some(rows[slot]), cols[slot]),
                    "{report}"
                );
            }
        }
    }
}
