//! The traditional spacetime formulation of the actuated rubber ball (seed §3.4, after Witkin &
//! Kass 1988) as an [`Nlp`]: positions are Hermite splines, the contact force is a variable,
//! and Newton's law is a set of collocated equality constraints.
//!
//! Knots `t₀ < … < t_N` sit on every frame `k/fps` and on every contact time (a frame closer
//! than a tenth of a frame to a contact time is moved onto it). Variables, per knot i:
//! position `pᵢ = (xᵢ, yᵢ)` (m) and slope `vᵢ = (ẋᵢ, ẏᵢ)` (m/s), four numbers; per knot strictly
//! inside a contact phase: the ground force `Fᵢ = (F_x, F_y)` (N). The force is piecewise
//! linear between knots and zero at touch-down, at take-off and in flight. On segment
//! `[tᵢ, tᵢ₊₁]`, `h = tᵢ₊₁ − tᵢ`, `τ = (t − tᵢ)/h` (seed eq. 3.15):
//! ```text
//!   r(t) = (2τ³−3τ²+1)·pᵢ + (τ³−2τ²+τ)·h·vᵢ + (−2τ³+3τ²)·pᵢ₊₁ + (τ³−τ²)·h·vᵢ₊₁
//!   r̈ at τ = 0:  6(pᵢ₊₁−pᵢ)/h² − (4vᵢ + 2vᵢ₊₁)/h;   at τ = 1:  −6(pᵢ₊₁−pᵢ)/h² + (2vᵢ + 4vᵢ₊₁)/h
//! ```
//! Constraints:
//! - Newtonian (seed eq. 3.10–3.12), at both ends of every segment (each knot from the left and
//!   from the right): `r̈ − F/m = (0, g)`. Since r̈ is linear on a segment, this makes r̈
//!   continuous and equal to the piecewise-linear `F/m + g` everywhere: in flight each segment is
//!   exactly a parabola, in contact the spline is the exact motion under the interpolated force.
//! - Mechanical (seed eq. 3.8): `−max_compression ≤ y ≤ 0` at touch-down (the floor is reached)
//!   and at knots in contact (the rubber ball deforms), `y = 0` at take-off, `y ≥ 0` at flight
//!   knots; `F_y ≥ 0` (the floor only pushes) and, with friction μ, `|F_x| ≤ μ·F_y`. Touch-down
//!   is an inequality, not the seed's `y = 0`: when the flight before it is fully determined
//!   (as from a given start state), `y = 0` there would repeat the Newtonian rows and leave the
//!   constraint gradients linearly dependent.
//! - Pose (seed eq. 3.7): start position and velocity, end position (variable bounds), and the
//!   file's `[[pose]]` rows `min ≤ r_axis(t) or ṙ_axis(t) ≤ max` anywhere in time.
//!
//! Objective (seed eq. 3.6): `G = ∫ |F|² dt`, exact for piecewise-linear F: per segment and axis
//! `h/3·(a² + a·b + b²)` (N²·s). Every constraint is linear and G is quadratic, so the Jacobian
//! and the Lagrangian Hessian (`σ·∇²G`) are constant; both are given exactly.
//!
//! Unlike the seed's version (instantaneous contacts, forces only at two instants), contact here
//! lasts a given phase and the force is finite, so the solution is a physically valid motion
//! (see [`super::validate`](mod@super::validate)).

use super::spec::{Problem, Quantity};
use crate::solver::{Dims, EvalError, Nlp};

/// Where a knot is relative to the contact phases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// In flight.
    Flight,
    /// At a touch-down time.
    TouchDown,
    /// Strictly inside a contact phase.
    Contact,
    /// At a take-off time.
    TakeOff,
}

/// The knot grid and the variable layout.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Knot times (s).
    pub times: Vec<f64>,
    /// Per knot: the index of its first force variable, if it is strictly inside a contact.
    pub force: Vec<Option<usize>>,
    /// Per knot: its place in the contact phases.
    pub contact: Vec<Phase>,
    /// Number of variables.
    pub n: usize,
}

impl Layout {
    /// Knots on every frame and contact time; variables laid out as in the module header.
    pub fn new(p: &Problem) -> Self {
        let frame = 1.0 / p.fps;
        let count = (p.duration * p.fps - 1e-9).ceil() as usize;
        let mut times: Vec<f64> = (0..count).map(|k| k as f64 * frame).collect();
        times.push(p.duration);
        let mut contact = vec![Phase::Flight; times.len()];
        for &(a, b) in &p.contacts {
            for (t, phase) in [(a, Phase::TouchDown), (b, Phase::TakeOff)] {
                let near = times.iter().position(|&s| (s - t).abs() < 0.1 * frame);
                match near {
                    Some(i) => {
                        times[i] = t;
                        contact[i] = phase;
                    }
                    None => {
                        let i = times.partition_point(|&s| s < t);
                        times.insert(i, t);
                        contact.insert(i, phase);
                    }
                }
            }
        }
        let mut n = 4 * times.len();
        let mut force = Vec::with_capacity(times.len());
        for (i, &t) in times.iter().enumerate() {
            if contact[i] == Phase::Flight && p.contacts.iter().any(|&(a, b)| t > a && t < b) {
                contact[i] = Phase::Contact;
                force.push(Some(n));
                n += 2;
            } else {
                force.push(None);
            }
        }
        Layout {
            times,
            force,
            contact,
            n,
        }
    }

    /// Number of segments.
    pub fn segments(&self) -> usize {
        self.times.len() - 1
    }

    /// The segment containing time `t` (the last one for `t` at the end) and τ ∈ [0, 1].
    pub fn locate(&self, t: f64) -> (usize, f64) {
        let s = self
            .times
            .partition_point(|&k| k <= t)
            .saturating_sub(1)
            .min(self.segments() - 1);
        let h = self.times[s + 1] - self.times[s];
        (s, ((t - self.times[s]) / h).clamp(0.0, 1.0))
    }

    /// Index of position (`slope = false`) or slope variable of `axis` at knot `i`.
    pub fn var(&self, i: usize, axis: usize, slope: bool) -> usize {
        4 * i + axis + if slope { 2 } else { 0 }
    }

    /// Coefficients of `(pᵢ, vᵢ, pᵢ₊₁, vᵢ₊₁)` in r (`order` 0), ṙ (1) or r̈ (2) on segment `s`
    /// at τ.
    pub fn basis(&self, s: usize, tau: f64, order: usize) -> [f64; 4] {
        let h = self.times[s + 1] - self.times[s];
        let (t2, t3) = (tau * tau, tau * tau * tau);
        match order {
            0 => [
                2.0 * t3 - 3.0 * t2 + 1.0,
                h * (t3 - 2.0 * t2 + tau),
                -2.0 * t3 + 3.0 * t2,
                h * (t3 - t2),
            ],
            1 => [
                (6.0 * t2 - 6.0 * tau) / h,
                3.0 * t2 - 4.0 * tau + 1.0,
                (-6.0 * t2 + 6.0 * tau) / h,
                3.0 * t2 - 2.0 * tau,
            ],
            _ => [
                (12.0 * tau - 6.0) / (h * h),
                (6.0 * tau - 4.0) / h,
                (-12.0 * tau + 6.0) / (h * h),
                (6.0 * tau - 2.0) / h,
            ],
        }
    }

    /// The four variables `(pᵢ, vᵢ, pᵢ₊₁, vᵢ₊₁)` of `axis` on segment `s`.
    pub fn segment_vars(&self, s: usize, axis: usize) -> [usize; 4] {
        [
            self.var(s, axis, false),
            self.var(s, axis, true),
            self.var(s + 1, axis, false),
            self.var(s + 1, axis, true),
        ]
    }

    /// r, ṙ or r̈ (by `order`) of `axis` at time `t` (m, m/s, m/s²).
    pub fn eval(&self, x: &[f64], axis: usize, order: usize, t: f64) -> f64 {
        let (s, tau) = self.locate(t);
        let b = self.basis(s, tau, order);
        let v = self.segment_vars(s, axis);
        (0..4).map(|k| b[k] * x[v[k]]).sum()
    }

    /// The ground force of `axis` at time `t` (N): piecewise linear between knots.
    pub fn force_at(&self, x: &[f64], axis: usize, t: f64) -> f64 {
        let (s, tau) = self.locate(t);
        let f = |i: usize| self.force[i].map_or(0.0, |j| x[j + axis]);
        (1.0 - tau) * f(s) + tau * f(s + 1)
    }
}

/// What one constraint row is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Row {
    /// Newton's law on segment `s` at its start (`end = false`) or end, one axis.
    Newton { s: usize, end: bool, axis: usize },
    /// The file's pose constraint `index`.
    Pose { index: usize },
    /// `sign·F_x − μ·F_y ≤ 0` at a force knot.
    Friction { knot: usize, sign: f64 },
}

/// The collocation NLP of one problem.
#[derive(Debug, Clone)]
pub struct Collocation<'a> {
    problem: &'a Problem,
    /// Knots and variables.
    pub layout: Layout,
    rows: Vec<Row>,
    /// Jacobian (row, col, value), constant.
    jacobian: Vec<(usize, usize, f64)>,
    /// Lower-triangle Hessian of G (row, col, value), constant.
    hessian: Vec<(usize, usize, f64)>,
}

impl<'a> Collocation<'a> {
    /// Builds the knot grid, the constraint rows and the constant derivatives.
    pub fn new(problem: &'a Problem) -> Self {
        let layout = Layout::new(problem);
        let mut rows = Vec::new();
        for s in 0..layout.segments() {
            for end in [false, true] {
                for axis in 0..2 {
                    rows.push(Row::Newton { s, end, axis });
                }
            }
        }
        rows.extend((0..problem.poses.len()).map(|index| Row::Pose { index }));
        if problem.friction.is_some() {
            for (knot, f) in layout.force.iter().enumerate() {
                if f.is_some() {
                    rows.push(Row::Friction { knot, sign: 1.0 });
                    rows.push(Row::Friction { knot, sign: -1.0 });
                }
            }
        }
        let mut nlp = Collocation {
            problem,
            layout,
            rows,
            jacobian: Vec::new(),
            hessian: Vec::new(),
        };
        nlp.jacobian = nlp.build_jacobian();
        nlp.hessian = nlp.build_hessian();
        nlp
    }

    fn build_jacobian(&self) -> Vec<(usize, usize, f64)> {
        let l = &self.layout;
        let mut out = Vec::new();
        for (r, row) in self.rows.iter().enumerate() {
            match *row {
                Row::Newton { s, end, axis } => {
                    let b = l.basis(s, if end { 1.0 } else { 0.0 }, 2);
                    for (v, c) in l.segment_vars(s, axis).into_iter().zip(b) {
                        out.push((r, v, c));
                    }
                    let knot = s + usize::from(end);
                    if let Some(j) = l.force[knot] {
                        out.push((r, j + axis, -1.0 / self.problem.mass));
                    }
                }
                Row::Pose { index } => {
                    let pose = &self.problem.poses[index];
                    let (s, tau) = l.locate(pose.time);
                    let order = match pose.quantity {
                        Quantity::Position => 0,
                        Quantity::Velocity => 1,
                    };
                    let b = l.basis(s, tau, order);
                    for (v, c) in l.segment_vars(s, pose.axis).into_iter().zip(b) {
                        out.push((r, v, c));
                    }
                }
                Row::Friction { knot, sign } => {
                    let j = l.force[knot].expect("friction rows sit on force knots");
                    let mu = self.problem.friction.unwrap_or(0.0);
                    out.push((r, j, sign));
                    out.push((r, j + 1, -mu));
                }
            }
        }
        out
    }

    /// ∇²G: per contact segment and axis, `h/3·[[2, 1], [1, 2]]` on the end forces.
    fn build_hessian(&self) -> Vec<(usize, usize, f64)> {
        let l = &self.layout;
        let mut diag = vec![0.0; l.n];
        let mut out = Vec::new();
        for s in 0..l.segments() {
            let h = l.times[s + 1] - l.times[s];
            for axis in 0..2 {
                let a = l.force[s].map(|j| j + axis);
                let b = l.force[s + 1].map(|j| j + axis);
                if let Some(a) = a {
                    diag[a] += 2.0 * h / 3.0;
                }
                if let Some(b) = b {
                    diag[b] += 2.0 * h / 3.0;
                }
                if let (Some(a), Some(b)) = (a, b) {
                    out.push((b.max(a), b.min(a), h / 3.0));
                }
            }
        }
        out.extend(
            diag.iter()
                .enumerate()
                .filter(|(_, d)| **d != 0.0)
                .map(|(j, &d)| (j, j, d)),
        );
        out
    }

    /// G = ∫|F|² dt (N²·s).
    pub fn objective(&self, x: &[f64]) -> f64 {
        let l = &self.layout;
        let mut g = 0.0;
        for s in 0..l.segments() {
            let h = l.times[s + 1] - l.times[s];
            for axis in 0..2 {
                let a = l.force[s].map_or(0.0, |j| x[j + axis]);
                let b = l.force[s + 1].map_or(0.0, |j| x[j + axis]);
                g += h / 3.0 * (a * a + a * b + b * b);
            }
        }
        g
    }

    /// A start point: straight-line positions (on the floor in contact, above it in flight),
    /// their finite-difference slopes, and forces carrying the weight.
    pub fn initial_guess(&self) -> Vec<f64> {
        let p = self.problem;
        let l = &self.layout;
        let mut x = vec![0.0; l.n];
        let (p0, p1) = (p.start.0, p.end);
        let pos = |i: usize, axis: usize| {
            let u = l.times[i] / p.duration;
            let v = p0[axis] + u * (p1[axis] - p0[axis]);
            match (axis, l.contact[i]) {
                (1, Phase::Flight) => v.max(0.0),
                (1, _) => 0.0,
                _ => v,
            }
        };
        let last = l.times.len() - 1;
        for i in 0..=last {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(last));
            for axis in 0..2 {
                x[l.var(i, axis, false)] = pos(i, axis);
                x[l.var(i, axis, true)] = (pos(b, axis) - pos(a, axis)) / (l.times[b] - l.times[a]);
            }
            if let Some(j) = l.force[i] {
                x[j + 1] = -p.mass * p.gravity;
            }
        }
        x
    }

    fn row_value(&self, x: &[f64], row: Row) -> f64 {
        let l = &self.layout;
        match row {
            Row::Newton { s, end, axis } => {
                let b = l.basis(s, if end { 1.0 } else { 0.0 }, 2);
                let v = l.segment_vars(s, axis);
                let acc: f64 = (0..4).map(|k| b[k] * x[v[k]]).sum();
                let knot = s + usize::from(end);
                acc - l.force[knot].map_or(0.0, |j| x[j + axis]) / self.problem.mass
            }
            Row::Pose { index } => {
                let pose = &self.problem.poses[index];
                let order = match pose.quantity {
                    Quantity::Position => 0,
                    Quantity::Velocity => 1,
                };
                l.eval(x, pose.axis, order, pose.time)
            }
            Row::Friction { knot, sign } => {
                let j = l.force[knot].expect("friction rows sit on force knots");
                sign * x[j] - self.problem.friction.unwrap_or(0.0) * x[j + 1]
            }
        }
    }
}

impl Nlp for Collocation<'_> {
    fn dims(&self) -> Dims {
        Dims {
            n: self.layout.n,
            m: self.rows.len(),
            jac_nnz: self.jacobian.len(),
            hess_nnz: self.hessian.len(),
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        let p = self.problem;
        let l = &self.layout;
        xl.fill(f64::NEG_INFINITY);
        xu.fill(f64::INFINITY);
        for (i, c) in l.contact.iter().enumerate() {
            let y = l.var(i, 1, false);
            let (lo, hi) = match c {
                Phase::TakeOff => (0.0, 0.0),
                Phase::TouchDown | Phase::Contact => (-p.max_compression, 0.0),
                Phase::Flight => (0.0, f64::INFINITY),
            };
            xl[y] = lo;
            xu[y] = hi;
            if let Some(j) = l.force[i] {
                xl[j + 1] = 0.0;
            }
        }
        let last = l.times.len() - 1;
        for axis in 0..2 {
            for (j, v) in [
                (l.var(0, axis, false), p.start.0[axis]),
                (l.var(0, axis, true), p.start.1[axis]),
                (l.var(last, axis, false), p.end[axis]),
            ] {
                xl[j] = v;
                xu[j] = v;
            }
        }
        for (r, row) in self.rows.iter().enumerate() {
            let (lo, hi) = match *row {
                Row::Newton { axis, .. } => {
                    let g = if axis == 1 { p.gravity } else { 0.0 };
                    (g, g)
                }
                Row::Pose { index } => (p.poses[index].min, p.poses[index].max),
                Row::Friction { .. } => (f64::NEG_INFINITY, 0.0),
            };
            cl[r] = lo;
            cu[r] = hi;
        }
    }

    fn start(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.initial_guess());
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for (k, &(r, c, _)) in self.jacobian.iter().enumerate() {
            rows[k] = r;
            cols[k] = c;
        }
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        if !x.iter().all(|v| v.is_finite()) {
            return Err(EvalError::Domain("non-finite spline or force value".into()));
        }
        *f = self.objective(x);
        for (r, &row) in self.rows.iter().enumerate() {
            c[r] = self.row_value(x, row);
        }
        Ok(())
    }

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        grad.fill(0.0);
        for &(r, c, v) in &self.hessian {
            grad[r] += v * x[c];
            if r != c {
                grad[c] += v * x[r];
            }
        }
        for (k, &(_, _, v)) in self.jacobian.iter().enumerate() {
            jac[k] = v;
        }
        Ok(())
    }

    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for (k, &(r, c, _)) in self.hessian.iter().enumerate() {
            rows[k] = r;
            cols[k] = c;
        }
    }

    fn eval_hessian(
        &self,
        _x: &[f64],
        sigma: f64,
        _lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        for (k, &(_, _, v)) in self.hessian.iter().enumerate() {
            values[k] = sigma * v;
        }
        Ok(())
    }

    fn constraint_name(&self, row: usize) -> String {
        let axis = |a: usize| if a == 0 { "x" } else { "y" };
        match self.rows[row] {
            Row::Newton { s, end, axis: a } => {
                let knot = s + usize::from(end);
                let side = if end { "left" } else { "right" };
                format!(
                    "newton {} at t = {:.4} s ({side})",
                    axis(a),
                    self.layout.times[knot]
                )
            }
            Row::Pose { index } => {
                let p = &self.problem.poses[index];
                format!("pose {} at t = {} s", axis(p.axis), p.time)
            }
            Row::Friction { knot, sign } => format!(
                "friction cone ({}) at t = {:.4} s",
                if sign > 0.0 { "+" } else { "−" },
                self.layout.times[knot]
            ),
        }
    }
}
