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
use crate::gait::sim::{Controls, SimError, Simulator, State, poll};
use crate::gait::spline::SplineControls;

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

    /// The Jacobian entries `(slot, value)` of the rows segment `k` owns. The sensitivity
    /// columns are the spline parameters and, when it is a variable, the segment's start state (seeded
    /// with the identity).
    fn segment_sensitivities(&self, k: usize, x: &[f64]) -> Result<Vec<(usize, f64)>, SimError> {
        let p = self.problem;
        let m = &p.model;
        let mut lin = StageLinearizer::new(m).expect("checked by the caller");
        let spline = SplineControls {
            grid: self.grid,
            params: x[..self.n_par].to_vec(),
        };
        let mut state = self.start_state(k, x);
        let mut step = StepTangent::new(m.nq, m.nv, m.actuators.len(), p.dt);
        let mut sens = Sensitivities::new(self, k, x.len());
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
                let t0 = n as f64 * p.dt;
                poll(Some(&self.problem.interrupt), n, t0)?;
                step.advance(&mut lin, &spline, &mut state, t0)?;
                self.propagate(&mut sens, &step, t0);
                n += 1;
            }
            match target {
                None => self.continuity_entries(k, &sens, &mut out),
                Some(_) => {
                    self.constraint_entries((k, i_sample), &state, &sens, &mut observer, &mut out)
                }
            }
        }
        Ok(out)
    }

    /// `S⁺ = Φ·S + Σ G_s·W_s` for the step from `t0` over the columns of knots whose support
    /// has started: S is stored knot-major ([`Self::knot_major`]), so they are a prefix (the
    /// other columns are zero in S and in the update; time only moves forward).
    fn propagate(&self, sens: &mut Sensitivities, step: &StepTangent, t0: f64) {
        let (nx, na, ncol, h) = (step.nx(), step.na, step.ncol, step.h);
        let n_par = sens.n_par;
        let block = self.grid.per_actuator();
        let basis: [_; 3] = std::array::from_fn(|st| self.grid.weights(t0 + 0.5 * h * st as f64));
        // Start-state columns (segments after the first) are live from the start.
        let live = if n_par > self.n_par {
            n_par
        } else {
            (basis[2].0[2] + 1) * 2 * na
        };
        // The Hermite terms G_s·W_s: (sensitivity column, T column, weight), in the order
        // (stage, actuator, basis function).
        sens.hermite.clear();
        for (st, (idx, wts)) in basis.iter().enumerate() {
            for a in 0..na {
                for (c, wc) in idx.iter().zip(wts) {
                    let entry = (self.knot_major(a * block + c), nx + st * na + a, *wc);
                    sens.hermite.push(entry);
                }
            }
        }
        let step_t = &step.step_t;
        for r in 0..nx {
            let row = &mut sens.next[r * n_par..r * n_par + live];
            row.fill(0.0);
            for i in 0..nx {
                let f = step_t[r * ncol + i];
                if f != 0.0 {
                    let src = &sens.s[i * n_par..i * n_par + live];
                    for (o, v) in row.iter_mut().zip(src) {
                        *o += f * v;
                    }
                }
            }
            let t_row = &step_t[r * ncol..(r + 1) * ncol];
            for &(col, g, wc) in &sens.hermite {
                row[col] += t_row[g] * wc;
            }
        }
        std::mem::swap(&mut sens.s, &mut sens.next);
    }

    /// Entries of the continuity defects `x(b_{k+1}) − s_{k+1}` at the end of segment `k`.
    fn continuity_entries(&self, k: usize, sens: &Sensitivities, out: &mut Vec<(usize, f64)>) {
        let nx = self.problem.model.nq + self.problem.model.nv;
        let n_var = sens.n_var;
        for i in 0..nx {
            let r = self.continuity_row(k + 1, i);
            for c in 0..sens.n_par {
                if let Some(slot) = self.slot[r * n_var + self.sensitivity_variable(k, c)] {
                    out.push((slot, sens.s[i * sens.n_par + self.sensitivity_column(c)]));
                }
            }
            let own = self.slot[r * n_var + self.state_column(k + 1, i)];
            out.push((own.expect("continuity pattern"), -1.0));
        }
    }

    /// Entries of the constraint rows sampled at `(segment, sample)`: `∂C/∂x·S`, with `∂C/∂x`
    /// by dual numbers, LANES directions at a time.
    fn constraint_entries(
        &self,
        (k, i_sample): (usize, usize),
        state: &State<f64>,
        sens: &Sensitivities,
        observer: &mut Simulator<DualSVec64<LANES>>,
        out: &mut Vec<(usize, f64)>,
    ) {
        let p = self.problem;
        let m = &p.model;
        let (nq, nx) = (m.nq, m.nq + m.nv);
        let n_var = sens.n_var;
        let mut grad_c = vec![0.0; nx];
        for (r, c) in p.constraints.iter().enumerate() {
            if self.row_sample[r] != (k, i_sample) {
                continue;
            }
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
                    q: (state.q.iter().enumerate())
                        .map(|(i, &z)| lift(i, z))
                        .collect(),
                    v: (state.v.iter().enumerate())
                        .map(|(i, &z)| lift(nq + i, z))
                        .collect(),
                };
                observer.observe(&xd);
                let val = c.quantity.value(m, &xd, &observer.dynamics);
                for i in start..nx.min(start + LANES) {
                    grad_c[i] = val.eps.0.as_ref().map_or(0.0, |e| e[i - start]);
                }
            }
            for j in 0..sens.n_par {
                if let Some(slot) = self.slot[r * n_var + self.sensitivity_variable(k, j)] {
                    let col = self.sensitivity_column(j);
                    let value = (0..nx)
                        .map(|i| grad_c[i] * sens.s[i * sens.n_par + col])
                        .sum();
                    out.push((slot, value));
                }
            }
        }
    }

    /// Global variable of sensitivity parameter `c` of segment `k` (spline parameters
    /// actuator-major, then the segment's start state).
    fn sensitivity_variable(&self, k: usize, c: usize) -> usize {
        if c < self.n_par {
            c
        } else {
            self.state_column(k, c - self.n_par)
        }
    }

    /// Column of parameter `c` in the sensitivity matrix: spline parameters stored knot-major
    /// ([`Self::knot_major`]), start-state columns after them.
    fn sensitivity_column(&self, c: usize) -> usize {
        if c < self.n_par {
            self.knot_major(c)
        } else {
            c
        }
    }
}

/// The sensitivities `S = ∂x/∂p` of one segment (row-major `nx × n_par`, knot-major columns),
/// their update buffer, and the Hermite terms of the current step.
struct Sensitivities {
    s: Vec<f64>,
    next: Vec<f64>,
    n_par: usize,
    /// Variables of the whole problem (Jacobian columns).
    n_var: usize,
    hermite: Vec<(usize, usize, f64)>,
}

impl Sensitivities {
    /// Zero sensitivities to the spline parameters; identity to segment `k`'s start state when
    /// it is a variable; `n_var` variables in all.
    fn new(reduced: &Reduced<'_>, k: usize, n_var: usize) -> Self {
        let m = &reduced.problem.model;
        let nx = m.nq + m.nv;
        let n_par = reduced.n_par + if reduced.has_state(k) { nx } else { 0 };
        let mut s = vec![0.0; nx * n_par];
        if reduced.has_state(k) {
            for i in 0..nx {
                s[i * n_par + reduced.n_par + i] = 1.0;
            }
        }
        Sensitivities {
            s,
            next: vec![0.0; nx * n_par],
            n_par,
            n_var,
            hermite: Vec::with_capacity(12 * m.actuators.len()),
        }
    }
}

/// RK4 stages: (time fraction, state increment fraction, force column block).
const STAGES: [(f64, f64, usize); 4] = [(0.0, 0.0, 0), (0.5, 0.5, 1), (0.5, 0.5, 1), (1.0, 1.0, 2)];

/// One RK4 step with its tangent `T = [Φ | G₀ | G½ | G₁]` (row-major `nx × ncol`, ncol =
/// nx + 3·na): the stage derivatives `k_s`, stage Jacobians `J_s`, `B_s` and their tangents `dk_s`.
struct StepTangent {
    na: usize,
    ncol: usize,
    /// Step, s.
    h: f64,
    stage: State<f64>,
    kq: Vec<Vec<f64>>,
    kv: Vec<Vec<f64>>,
    jx: Vec<Vec<f64>>,
    ju: Vec<Vec<f64>>,
    forces: Vec<f64>,
    dk: Vec<Vec<f64>>,
    step_t: Vec<f64>,
}

impl StepTangent {
    fn new(nq: usize, nv: usize, na: usize, h: f64) -> Self {
        let nx = nq + nv;
        let ncol = nx + 3 * na;
        StepTangent {
            na,
            ncol,
            h,
            stage: State {
                q: vec![0.0; nq],
                v: vec![0.0; nv],
            },
            kq: vec![vec![0.0; nq]; 4],
            kv: vec![vec![0.0; nv]; 4],
            jx: vec![vec![0.0; nx * nx]; 4],
            ju: vec![vec![0.0; nx * na]; 4],
            forces: vec![0.0; na],
            dk: vec![vec![0.0; nx * ncol]; 4],
            step_t: vec![0.0; nx * ncol],
        }
    }

    fn nx(&self) -> usize {
        self.ncol - 3 * self.na
    }

    /// Advances `state` by the RK4 step from `t0` (arithmetic as in `Simulator::step`) and
    /// fills the step tangent.
    fn advance(
        &mut self,
        lin: &mut StageLinearizer,
        spline: &SplineControls<f64>,
        state: &mut State<f64>,
        t0: f64,
    ) -> Result<(), SimError> {
        let h = self.h;
        for (s, &(dt_frac, x_frac, _)) in STAGES.iter().enumerate() {
            if s == 0 {
                self.stage.q.copy_from_slice(&state.q);
                self.stage.v.copy_from_slice(&state.v);
            } else {
                let w = h * x_frac;
                for ((t, x0), k) in self.stage.q.iter_mut().zip(&state.q).zip(&self.kq[s - 1]) {
                    *t = *x0 + *k * w;
                }
                for ((t, x0), k) in self.stage.v.iter_mut().zip(&state.v).zip(&self.kv[s - 1]) {
                    *t = *x0 + *k * w;
                }
            }
            spline.forces(t0 + dt_frac * h, &mut self.forces);
            lin.evaluate(
                &self.stage.q,
                &self.stage.v,
                &self.forces,
                &mut self.kq[s],
                &mut self.kv[s],
                &mut self.jx[s],
                &mut self.ju[s],
            );
        }
        let w = h / 6.0;
        let kq = &self.kq;
        for (xq, j) in state.q.iter_mut().zip(0..) {
            *xq += (kq[0][j] + (kq[1][j] + kq[2][j]) * 2.0 + kq[3][j]) * w;
        }
        let kv = &self.kv;
        for (xv, j) in state.v.iter_mut().zip(0..) {
            *xv += (kv[0][j] + (kv[1][j] + kv[2][j]) * 2.0 + kv[3][j]) * w;
        }
        if !state.q.iter().chain(&state.v).all(|z| z.is_finite()) {
            return Err(SimError::not_finite(t0 + h));
        }
        self.tangent();
        Ok(())
    }

    /// `dk_s = J_s·(D + c_s·dk_{s−1}) + B_s·E_s` and `T = D + h/6·(dk₁ + 2dk₂ + 2dk₃ + dk₄)`.
    fn tangent(&mut self) {
        let (nx, na, ncol, h) = (self.nx(), self.na, self.ncol, self.h);
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
        let (dk, w) = (&self.dk, h / 6.0);
        for (i, t) in self.step_t.iter_mut().enumerate() {
            *t = (dk[0][i] + (dk[1][i] + dk[2][i]) * 2.0 + dk[3][i]) * w;
        }
        for r in 0..nx {
            self.step_t[r * ncol + r] += 1.0;
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
