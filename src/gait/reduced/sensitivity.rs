//! Exact Jacobian of the pose constraints by forward sensitivities of the discrete RK4 map.
//!
//! With the stage Jacobians `J_s = ∂f/∂x`, `B_s = ∂f/∂u` of [`StageLinearizer`] (analytical
//! ABA derivatives), one RK4 step `x⁺ = x + h/6·(k₁ + 2k₂ + 2k₃ + k₄)` is differentiated exactly
//! with respect to `x` and to the actuator forces at its three distinct stage times
//! `t, t + h/2, t + h` (columns `E₀, E½, E₁` of a tangent block `[I | 0 | 0 | 0]`):
//! ```text
//!   dk₁ = J₁·D + B₁E₀,  dk₂ = J₂(D + h/2·dk₁) + B₂E½,  dk₃ = J₃(D + h/2·dk₂) + B₃E½,
//!   dk₄ = J₄(D + h·dk₃) + B₄E₁,   T = D + h/6·(dk₁ + 2dk₂ + 2dk₃ + dk₄) = [Φ | G₀ | G½ | G₁]
//! ```
//! and the parameter sensitivities `S = ∂x/∂p` follow `S⁺ = Φ·S + Σ_s G_s·W_s`, where `W_s` is
//! the Hermite basis at stage time `s` (four nonzeros per actuator). The work per step is four
//! analytical linearizations plus small dense products, independent of how the parameters
//! enter. A constraint row is `∂C/∂x·S` at its sample, with `∂C/∂x` from dual numbers (a few
//! evaluations per sample). Agrees with the dual-number oracle
//! ([`Reduced::jacobian_by_parameter_duals`]) to round-off.

// Index loops mirror the matrix subscripts.
#![allow(clippy::needless_range_loop)]

use num_dual::DualSVec64;
use rayon::prelude::*;

use super::Reduced;
use crate::gait::aba::derivatives::StageLinearizer;
use crate::gait::character::Model;
use crate::gait::sim::{Controls, SimError, Simulator, State, poll};
use crate::gait::spline::SplineControls;
use crate::gait::task::Quantity;

/// Dual directions per evaluation of a constraint's state gradient.
const LANES: usize = 8;

impl Reduced<'_> {
    /// Jacobian values (pattern order) by forward sensitivities through RK4 with analytical
    /// stage Jacobians, one segment per task (rayon). Returns `Ok(false)` without touching
    /// `jac` if the model has a joint the analytical path does not cover (a floating base).
    pub fn jacobian_by_sensitivities(&self, x: &[f64], jac: &mut [f64]) -> Result<bool, SimError> {
        if StageLinearizer::new(&self.problem.model).is_none() {
            return Ok(false);
        }
        let parts: Vec<Result<Vec<(usize, f64)>, SimError>> = (0..self.segments())
            .into_par_iter()
            .map(|k| self.segment_sensitivities(k, x))
            .collect();
        for part in parts {
            for (slot, v) in part? {
                jac[slot] = v;
            }
        }
        Ok(true)
    }
}

/// The RK4 stages: (fraction of `h` at the stage time, fraction of `h` of the state offset,
/// index of the stage's force columns `E₀, E½, E₁` in the tangent block).
const STAGES: [(f64, f64, usize); 4] = [(0.0, 0.0, 0), (0.5, 0.5, 1), (0.5, 0.5, 1), (1.0, 1.0, 2)];

/// One segment's forward sweep: the RK4 state, the stage derivatives and Jacobians of the
/// current step, its tangent `T`, and the sensitivities `S = ∂x/∂p`. Matrices are dense and
/// row-major; `x = (q, v)` has `nx = nq + nv` entries (SI units of the model: m, rad, m/s,
/// rad/s), the actuator forces `na` (N or N·m).
struct Sweep {
    nq: usize,
    na: usize,
    /// Variables of the problem (the length of `x`).
    n_var: usize,
    nx: usize,
    /// Columns of the tangent block `[I | E₀ | E½ | E₁]`: `nx + 3·na`.
    ncol: usize,
    /// Columns of `S`: the spline parameters (knot-major), then the start state if variable.
    n_par: usize,
    /// Time step, s.
    h: f64,
    state: State<f64>,
    /// The state at the current stage.
    tmp: State<f64>,
    /// Stage derivatives `k_s` of `q` and `v`.
    kq: Vec<Vec<f64>>,
    kv: Vec<Vec<f64>>,
    /// Stage Jacobians `J_s` (nx × nx) and `B_s` (nx × na).
    jx: Vec<Vec<f64>>,
    ju: Vec<Vec<f64>>,
    /// Actuator forces at the current stage time.
    act: Vec<f64>,
    /// `dk_s` (nx × ncol) and the step tangent `T` (nx × ncol).
    dk: Vec<Vec<f64>>,
    step_t: Vec<f64>,
    /// `S` (nx × n_par) and the buffer of its update.
    sens: Vec<f64>,
    next: Vec<f64>,
    /// The Hermite terms `G_s·W_s` of a step: (sensitivity column, T column, weight).
    hermite: Vec<(usize, usize, f64)>,
}

impl Sweep {
    /// The sweep at the start of segment `k`, `S` seeded with the identity on the start-state
    /// columns when the start state is a variable.
    fn new(reduced: &Reduced<'_>, k: usize, x: &[f64]) -> Self {
        let p = reduced.problem;
        let m = &p.model;
        let (nq, nv, na) = (m.nq, m.nv, m.actuators.len());
        let nx = nq + nv;
        let ncol = nx + 3 * na;
        let n_par = reduced.n_par + if reduced.has_state(k) { nx } else { 0 };
        let state = reduced.start_state(k, x);
        let tmp = state.clone();
        let mut sens = vec![0.0; nx * n_par];
        if reduced.has_state(k) {
            for i in 0..nx {
                sens[i * n_par + reduced.n_par + i] = 1.0;
            }
        }
        Sweep {
            nq,
            na,
            n_var: x.len(),
            nx,
            ncol,
            n_par,
            h: p.dt,
            state,
            tmp,
            kq: vec![vec![0.0; nq]; 4],
            kv: vec![vec![0.0; nv]; 4],
            jx: vec![vec![0.0; nx * nx]; 4],
            ju: vec![vec![0.0; nx * na]; 4],
            act: vec![0.0; na],
            dk: vec![vec![0.0; nx * ncol]; 4],
            step_t: vec![0.0; nx * ncol],
            sens,
            next: vec![0.0; nx * n_par],
            hermite: Vec::with_capacity(12 * na),
        }
    }

    /// One RK4 step from time `t0` (s), arithmetic as in `Simulator::step`, keeping the stage
    /// Jacobians. Fails when the new state is not finite.
    fn rk4_step(
        &mut self,
        lin: &mut StageLinearizer<'_>,
        spline: &SplineControls<f64>,
        t0: f64,
    ) -> Result<(), SimError> {
        let h = self.h;
        for (s, &(dt_frac, x_frac, _)) in STAGES.iter().enumerate() {
            if s == 0 {
                self.tmp.q.copy_from_slice(&self.state.q);
                self.tmp.v.copy_from_slice(&self.state.v);
            } else {
                let w = h * x_frac;
                for ((t, x0), k) in self
                    .tmp
                    .q
                    .iter_mut()
                    .zip(&self.state.q)
                    .zip(&self.kq[s - 1])
                {
                    *t = *x0 + *k * w;
                }
                for ((t, x0), k) in self
                    .tmp
                    .v
                    .iter_mut()
                    .zip(&self.state.v)
                    .zip(&self.kv[s - 1])
                {
                    *t = *x0 + *k * w;
                }
            }
            spline.forces(t0 + dt_frac * h, &mut self.act);
            lin.evaluate(
                &self.tmp.q,
                &self.tmp.v,
                &self.act,
                &mut self.kq[s],
                &mut self.kv[s],
                &mut self.jx[s],
                &mut self.ju[s],
            );
        }
        let w = h / 6.0;
        let (kq, kv) = (&self.kq, &self.kv);
        for (xq, j) in self.state.q.iter_mut().zip(0..) {
            *xq += (kq[0][j] + (kq[1][j] + kq[2][j]) * 2.0 + kq[3][j]) * w;
        }
        for (xv, j) in self.state.v.iter_mut().zip(0..) {
            *xv += (kv[0][j] + (kv[1][j] + kv[2][j]) * 2.0 + kv[3][j]) * w;
        }
        if !self
            .state
            .q
            .iter()
            .chain(&self.state.v)
            .all(|z| z.is_finite())
        {
            return Err(SimError::not_finite(t0 + h));
        }
        Ok(())
    }

    /// The tangent of the last step, `T = [Φ | G₀ | G½ | G₁]`, from its stage Jacobians
    /// (the `dk_s` recursion of the module header).
    fn step_tangent(&mut self) {
        let (nx, na, ncol, h) = (self.nx, self.na, self.ncol, self.h);
        for s in 0..4 {
            let (prev, rest) = self.dk.split_at_mut(s);
            let out = &mut rest[0];
            out.fill(0.0);
            let (j, b) = (&self.jx[s], &self.ju[s]);
            for r in 0..nx {
                let row = &mut out[r * ncol..(r + 1) * ncol];
                row[..nx].copy_from_slice(&j[r * nx..(r + 1) * nx]);
                let u0 = nx + STAGES[s].2 * na;
                row[u0..u0 + na].copy_from_slice(&b[r * na..(r + 1) * na]);
            }
            if s > 0 {
                let c = h * STAGES[s].1;
                let d_prev = &prev[s - 1];
                // dk_{s−1} is zero right of the force columns of its stage time.
                let width = nx + (STAGES[s - 1].2 + 1) * na;
                for r in 0..nx {
                    let row = &mut out[r * ncol..r * ncol + width];
                    for i in 0..nx {
                        let f = c * j[r * nx + i];
                        if f != 0.0 {
                            let src = &d_prev[i * ncol..i * ncol + width];
                            for (o, v) in row.iter_mut().zip(src) {
                                *o += f * v;
                            }
                        }
                    }
                }
            }
        }
        let w = h / 6.0;
        let dk = &self.dk;
        for (i, t) in self.step_t.iter_mut().enumerate() {
            *t = (dk[0][i] + (dk[1][i] + dk[2][i]) * 2.0 + dk[3][i]) * w;
        }
        for r in 0..nx {
            self.step_t[r * ncol + r] += 1.0;
        }
    }

    /// `∂C/∂x` of `quantity` at the current state, by dual numbers, LANES directions at a time.
    fn state_gradient(
        &self,
        m: &Model,
        quantity: &Quantity,
        observer: &mut Simulator<DualSVec64<LANES>>,
    ) -> Vec<f64> {
        let (nq, nx) = (self.nq, self.nx);
        let mut grad_c = vec![0.0; nx];
        for start in (0..nx).step_by(LANES) {
            let lift = |i: usize, z: f64| {
                let d = DualSVec64::<LANES>::from_re(z);
                if (start..start + LANES).contains(&i) {
                    d.derivative(i - start)
                } else {
                    d
                }
            };
            let xd = State {
                q: (self.state.q.iter().enumerate())
                    .map(|(i, &z)| lift(i, z))
                    .collect(),
                v: (self.state.v.iter().enumerate())
                    .map(|(i, &z)| lift(nq + i, z))
                    .collect(),
            };
            observer.observe(&xd);
            let val = quantity.value(m, &xd, &observer.dynamics);
            for i in start..nx.min(start + LANES) {
                grad_c[i] = val.eps.0.as_ref().map_or(0.0, |e| e[i - start]);
            }
        }
        grad_c
    }
}

impl Reduced<'_> {
    /// The Jacobian entries `(slot, value)` of the rows segment `k` owns. The sensitivity
    /// columns are the spline parameters and, when it is a variable, the segment's start state (seeded
    /// with the identity).
    fn segment_sensitivities(&self, k: usize, x: &[f64]) -> Result<Vec<(usize, f64)>, SimError> {
        let m = &self.problem.model;
        let mut lin = StageLinearizer::new(m).expect("checked by the caller");
        let spline = SplineControls {
            grid: self.grid,
            params: x[..self.n_par].to_vec(),
        };
        let mut sweep = Sweep::new(self, k, x);
        let mut observer = Simulator::<DualSVec64<LANES>>::new(m);
        let mut out = Vec::new();
        let mut n = self.boundaries[k];
        let mut targets: Vec<Option<usize>> = self.samples[k].iter().map(|&t| Some(t)).collect();
        if k + 1 < self.segments() {
            targets.push(None);
        }
        for (i_sample, target) in targets.into_iter().enumerate() {
            let end = target.unwrap_or(self.boundaries[(k + 1).min(self.segments())]);
            while n < end {
                let t0 = n as f64 * sweep.h;
                poll(Some(&self.problem.interrupt), n, t0)?;
                sweep.rk4_step(&mut lin, &spline, t0)?;
                sweep.step_tangent();
                self.advance_sensitivities(&mut sweep, t0);
                n += 1;
            }
            match target {
                None => self.continuity_entries(k, &sweep, &mut out),
                Some(_) => self.constraint_entries(k, i_sample, &sweep, &mut observer, &mut out),
            }
        }
        Ok(out)
    }

    /// Variable `c` of segment `k`'s sweep (spline parameters actuator-major, then the
    /// segment's start state): its global column.
    fn sweep_global_column(&self, k: usize, c: usize) -> usize {
        if c < self.n_par {
            c
        } else {
            self.state_column(k, c - self.n_par)
        }
    }

    /// Variable `c` of a sweep: its column in the sensitivity matrix (spline parameters
    /// stored knot-major, [`Self::knot_major`]; start-state columns after them).
    fn sweep_column(&self, c: usize) -> usize {
        if c < self.n_par {
            self.knot_major(c)
        } else {
            c
        }
    }

    /// `S⁺ = Φ·S + Σ G_s·W_s` for the step from `t0` (s) whose tangent `sweep` holds, over
    /// the columns of knots whose support has started: S is stored knot-major
    /// ([`Self::knot_major`]), so they are a prefix (the other columns are zero in S and in
    /// the update; time only moves forward).
    fn advance_sensitivities(&self, sweep: &mut Sweep, t0: f64) {
        let (nx, na, ncol, n_par, h) = (sweep.nx, sweep.na, sweep.ncol, sweep.n_par, sweep.h);
        let block = self.grid.per_actuator();
        let basis: [_; 3] = std::array::from_fn(|st| self.grid.weights(t0 + 0.5 * h * st as f64));
        // Start-state columns (segments after the first) are live from the start.
        let live = if n_par > self.n_par {
            n_par
        } else {
            (basis[2].0[2] + 1) * 2 * na
        };
        // The Hermite terms G_s·W_s: (sensitivity column, T column, weight), in the
        // order (stage, actuator, basis function).
        sweep.hermite.clear();
        for (st, (idx, wts)) in basis.iter().enumerate() {
            for a in 0..na {
                for (c, wc) in idx.iter().zip(wts) {
                    sweep
                        .hermite
                        .push((self.knot_major(a * block + c), nx + st * na + a, *wc));
                }
            }
        }
        for r in 0..nx {
            let row = &mut sweep.next[r * n_par..r * n_par + live];
            row.fill(0.0);
            for i in 0..nx {
                let f = sweep.step_t[r * ncol + i];
                if f != 0.0 {
                    let src = &sweep.sens[i * n_par..i * n_par + live];
                    for (o, v) in row.iter_mut().zip(src) {
                        *o += f * v;
                    }
                }
            }
            let t_row = &sweep.step_t[r * ncol..(r + 1) * ncol];
            for &(col, g, wc) in &sweep.hermite {
                row[col] += t_row[g] * wc;
            }
        }
        std::mem::swap(&mut sweep.sens, &mut sweep.next);
    }

    /// The entries of the continuity defects `x(b_{k+1}) − s_{k+1}` at the end of segment `k`.
    fn continuity_entries(&self, k: usize, sweep: &Sweep, out: &mut Vec<(usize, f64)>) {
        let (n_var, n_par) = (sweep.n_var, sweep.n_par);
        for i in 0..sweep.nx {
            let r = self.continuity_row(k + 1, i);
            for c in 0..n_par {
                if let Some(slot) = self.slot[r * n_var + self.sweep_global_column(k, c)] {
                    out.push((slot, sweep.sens[i * n_par + self.sweep_column(c)]));
                }
            }
            let own = self.slot[r * n_var + self.state_column(k + 1, i)];
            out.push((own.expect("continuity pattern"), -1.0));
        }
    }

    /// The entries `∂C/∂x·S` of the constraint rows sampled at sample `i_sample` of segment `k`.
    fn constraint_entries(
        &self,
        k: usize,
        i_sample: usize,
        sweep: &Sweep,
        observer: &mut Simulator<DualSVec64<LANES>>,
        out: &mut Vec<(usize, f64)>,
    ) {
        let p = self.problem;
        let (nx, n_var, n_par) = (sweep.nx, sweep.n_var, sweep.n_par);
        for (r, c) in p.constraints.iter().enumerate() {
            if self.row_sample[r] != (k, i_sample) {
                continue;
            }
            let grad_c = sweep.state_gradient(&p.model, &c.quantity, observer);
            for j in 0..n_par {
                if let Some(slot) = self.slot[r * n_var + self.sweep_global_column(k, j)] {
                    let col = self.sweep_column(j);
                    out.push((
                        slot,
                        (0..nx)
                            .map(|i| grad_c[i] * sweep.sens[i * n_par + col])
                            .sum(),
                    ));
                }
            }
        }
    }
}

impl Reduced<'_> {
    /// Column of parameter `j` (actuator-major: actuator, then values, then slopes) in the
    /// knot-major order of the sensitivity matrix: knot, then value/slope, then actuator. The
    /// parameters of knots `0..k` are then the first `2·k·na` columns.
    fn knot_major(&self, j: usize) -> usize {
        let na = self.problem.model.actuators.len();
        let (knots, block) = (self.grid.knots, self.grid.per_actuator());
        let (a, r) = (j / block, j % block);
        ((r % knots) * 2 + r / knots) * na + a
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{gap_to_oracle, shortened};
    use super::*;
    use crate::solver::Nlp;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn sensitivities_match_the_dual_number_oracle() {
        for (name, factor) in [("pogo_jump", 0.2), ("luxo_leap", 0.2), ("biped_hop", 0.05)] {
            let p = shortened(name, factor);
            let nlp = Reduced::new(&p);
            let d = nlp.dims();
            let mut rng = ChaCha8Rng::seed_from_u64(5);
            let crate::solver::Bounds { xl, xu, .. } = crate::solver::Bounds::of(&nlp);
            let x: Vec<f64> = (0..d.n)
                .map(|j| {
                    let span = if xl[j].is_finite() {
                        (xu[j] - xl[j]) / 6.0
                    } else {
                        20.0
                    };
                    rng.random_range(-span..span)
                })
                .collect();
            let (mut fast, mut oracle) = (vec![0.0; d.jac_nnz], vec![0.0; d.jac_nnz]);
            assert!(nlp.jacobian_by_sensitivities(&x, &mut fast).unwrap());
            nlp.jacobian_by_parameter_duals(&x, &mut oracle).unwrap();
            assert!(fast.iter().all(|v| v.is_finite()), "{name}: not finite");
            let largest = oracle.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            let gap = gap_to_oracle(&fast, &oracle);
            println!(
                "{name}: nnz = {}, max |J| = {largest:.2e}, max |sensitivity − dual| / max(|dual|, 1e-3·max|J|) = {gap:.2e}",
                d.jac_nnz
            );
            assert!(gap < 1e-9, "{name}: {gap}");
        }
    }
}
