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
use crate::gait::character::{ForcePartials, Model};
use crate::gait::sim::{Controls, SimError, Simulator, State, poll};
use crate::gait::spline::SplineControls;

/// Dual directions per evaluation of a constraint's state gradient.
const LANES: usize = 8;

impl Reduced<'_> {
    /// Jacobian values (pattern order) by forward sensitivities through RK4 with analytical
    /// stage Jacobians, one segment per task (rayon). When the effort is integrated along the
    /// rollout (servos), its gradient is written into `grad` too (else `grad` is untouched).
    /// Returns `Ok(false)` without touching `jac` or `grad` if the model has a joint the
    /// analytical path does not cover (a floating base).
    pub fn jacobian_by_sensitivities(
        &self,
        x: &[f64],
        jac: &mut [f64],
        grad: &mut [f64],
    ) -> Result<bool, SimError> {
        if StageLinearizer::new(&self.problem.model).is_none() {
            return Ok(false);
        }
        let parts: Vec<Result<SegmentEntries, SimError>> = (0..self.segments())
            .into_par_iter()
            .map(|k| self.segment_sensitivities(k, x))
            .collect();
        if self.effort_by_rollout() {
            grad.fill(0.0);
        }
        for part in parts {
            let (entries, effort) = part?;
            for (slot, v) in entries {
                jac[slot] = v;
            }
            for (j, g) in effort {
                grad[j] += g;
            }
        }
        Ok(true)
    }

    /// The Jacobian entries `(slot, value)` of the rows segment `k` owns, and (servos) the
    /// gradient entries `(variable, value)` of its effort. The sensitivity columns are the
    /// spline parameters and, when it is a variable, the segment's start state (seeded with the
    /// identity).
    fn segment_sensitivities(&self, k: usize, x: &[f64]) -> Result<SegmentEntries, SimError> {
        let p = self.problem;
        let m = &p.model;
        let mut lin = StageLinearizer::new(m).expect("checked by the caller");
        let spline = SplineControls {
            grid: self.grid,
            params: x[..self.n_par].to_vec(),
        };
        let mut state = self.start_state(k, x);
        let mut step = StepTangent::new(m, p.dt, self.effort_by_rollout());
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
        if !step.effort {
            return Ok((out, Vec::new()));
        }
        if k + 1 == self.segments() {
            while n < self.last_step() {
                let t0 = n as f64 * p.dt;
                poll(Some(&self.problem.interrupt), n, t0)?;
                step.advance(&mut lin, &spline, &mut state, t0)?;
                self.propagate(&mut sens, &step, t0);
                n += 1;
            }
        }
        let effort = (0..sens.n_par)
            .map(|c| {
                let g = sens.effort[self.sensitivity_column(c)];
                (self.sensitivity_variable(k, c), g)
            })
            .collect();
        Ok((out, effort))
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
        if step.effort {
            // e⁺ = e + ∂e⁺/∂x·S + Σ ∂e⁺/∂u_s·W_s.
            let e_t = &step.effort_t;
            for i in 0..nx {
                if e_t[i] != 0.0 {
                    let src = &sens.s[i * n_par..i * n_par + live];
                    for (o, v) in sens.effort[..live].iter_mut().zip(src) {
                        *o += e_t[i] * v;
                    }
                }
            }
            for &(col, g, wc) in &sens.hermite {
                sens.effort[col] += e_t[g] * wc;
            }
        }
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

/// A segment's Jacobian entries `(slot, value)` and effort gradient entries `(variable, value)`.
type SegmentEntries = (Vec<(usize, f64)>, Vec<(usize, f64)>);

/// The sensitivities `S = ∂x/∂p` of one segment (row-major `nx × n_par`, knot-major columns),
/// their update buffer, the effort's sensitivities (servos; same columns), and the Hermite terms
/// of the current step.
struct Sensitivities {
    s: Vec<f64>,
    effort: Vec<f64>,
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
            effort: vec![0.0; n_par],
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
/// With the effort integrated along the rollout (servos), also the tangent of its step
/// `e⁺ = e + h/6·Σ_s w_s·Σ_a τ_a(x_s, u_s)²` (`w = 1, 2, 2, 1`, `x_s` the stage states):
/// `∂e⁺ = h/6·Σ_s w_s·Σ_a 2τ_a·(∂τ_a/∂x·dx_s + ∂τ_a/∂u·E_s)` with `dx_s = D + c_s·dk_{s−1}`.
struct StepTangent {
    /// Whether the effort's tangent is computed.
    effort: bool,
    /// Per actuator, the state rows of its joint's coordinate and rate.
    joints: Vec<(usize, usize)>,
    /// Per stage and actuator, the force and its partials.
    partials: Vec<Vec<ForcePartials>>,
    /// `∂e⁺/∂(x, u₀, u½, u₁)` (length ncol).
    effort_t: Vec<f64>,
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
    fn new(model: &Model, h: f64, effort: bool) -> Self {
        let (nq, nv, na) = (model.nq, model.nv, model.actuators.len());
        let nx = nq + nv;
        let ncol = nx + 3 * na;
        let joints = model
            .actuators
            .iter()
            .map(|a| {
                let l = &model.links[a.link];
                (l.q_index, nq + l.v_index)
            })
            .collect();
        let unit = ForcePartials {
            force: 0.0,
            d_control: 1.0,
            d_position: 0.0,
            d_rate: 0.0,
        };
        StepTangent {
            effort,
            joints,
            partials: vec![vec![unit; na]; 4],
            effort_t: vec![0.0; ncol],
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
            self.partials[s].copy_from_slice(&lin.forces);
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
        if self.effort {
            self.effort_tangent();
        }
        Ok(())
    }

    /// `∂e⁺/∂(x, u)` of the effort's step (type header), from the stage tangents `dk_s`.
    fn effort_tangent(&mut self) {
        let (nx, na, ncol, h) = (self.nx(), self.na, self.ncol, self.h);
        self.effort_t.fill(0.0);
        for (s, &(_, x_frac, block)) in STAGES.iter().enumerate() {
            let w = h / 6.0 * if s == 1 || s == 2 { 2.0 } else { 1.0 };
            for (a, (f, &(qi, vi))) in self.partials[s].iter().zip(&self.joints).enumerate() {
                let g = 2.0 * f.force * w;
                if g == 0.0 {
                    continue;
                }
                let (gq, gv) = (g * f.d_position, g * f.d_rate);
                self.effort_t[qi] += gq;
                self.effort_t[vi] += gv;
                self.effort_t[nx + block * na + a] += g * f.d_control;
                if s > 0 {
                    let c = h * x_frac;
                    let prev = &self.dk[s - 1];
                    let (row_q, row_v) = (
                        &prev[qi * ncol..(qi + 1) * ncol],
                        &prev[vi * ncol..(vi + 1) * ncol],
                    );
                    for ((o, dq), dv) in self.effort_t.iter_mut().zip(row_q).zip(row_v) {
                        *o += c * (gq * dq + gv * dv);
                    }
                }
            }
        }
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
            let mut grad = vec![0.0; d.n];
            assert!(
                nlp.jacobian_by_sensitivities(&x, &mut fast, &mut grad)
                    .unwrap()
            );
            nlp.jacobian_by_parameter_duals(&x, &mut oracle, &mut grad)
                .unwrap();
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
