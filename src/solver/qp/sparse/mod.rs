//! Sparse convex QP by a primal-dual interior-point method (Mehrotra predictor–corrector).
//!
//! ```text
//!     min ½ dᵀH d + gᵀd   s.t.   dl ≤ d ≤ du,   bl ≤ A d ≤ bu
//! ```
//! Inequality rows get a slack s = A d with bl ≤ s ≤ bu; every finite, non-fixed bound is a
//! complementarity pair (t, z) with t > 0 its distance to the bound, z ≥ 0 its multiplier:
//! ```text
//!     H d + g + Aᵀy − z_l + z_u = 0          (dual residual r_d)
//!     A d − s = 0  /  A_E d − b_E = 0        (primal residual r_p)
//!     −y − w_l + w_u = 0                     (inequality rows: y = w_u − w_l)
//!     t ∘ z = σμ                              (complementarity, μ = tᵀz / #pairs)
//! ```
//! so that the reported multipliers λ = y and z = z_u − z_l follow [`QpSolution`]'s convention
//! `Hd + g + Aᵀλ + z = 0`, λ ≤ 0 at an active lower bound, ≥ 0 at an active upper one.
//! Eliminating the slacks and bound multipliers leaves the quasi-definite system of
//! `newton.rs` (Nocedal & Wright, *Numerical Optimization* 2nd ed., §16.6; Mehrotra 1992; the
//! bound handling of Gertz & Wright 2003, OOQP). Fixed variables (dl = du) stay at their value
//! with a free multiplier; free rows get λ = 0. Primal and dual iterates take a common step
//! (a QP's dual residual involves d), at 0.995 of the distance to the boundary.
//!
//! Termination (`tolerance` ε, relative):
//! `|r_p,i| ≤ ε(1 + max(|(Ad)_i|, |s_i| or |b_i|))` row by row, `‖r_d‖∞ ≤ ε(1 + max(‖Hd‖∞, ‖g‖∞, ‖Aᵀy‖∞, ‖z‖∞))`
//! and `tᵀz ≤ ε(1 + |½dᵀHd + gᵀd|)`.
//!
//! Infeasibility: the dual iterates are tested every iteration as a Farkas certificate. With
//! `S = dlᵀz_l − duᵀz_u + blᵀw_l − buᵀw_u − b_Eᵀy_E` (finite bounds; fixed variables add
//! `dl_j (Aᵀy)_j`) and `R = ‖Aᵀy − z_l + z_u‖∞` (fixed variables excluded), every feasible d
//! satisfies `S ≤ ‖d‖₁ R`; so `S > 10⁶ (1 + ‖d_k‖₁) R` proves that no feasible point lies within
//! that ℓ₁ radius, and the QP is reported [`QpStatus::Infeasible`]. A primal residual that stops
//! halving (over 5 iterations) while the dual residual and the complementarity have converged
//! marks a least-infeasible point: `Infeasible`, unless the residual is below 1e-5 (relative),
//! where it ends `Optimal`: near feasibility the complementarity can converge first, the
//! iterates then sit on the boundary and the residual shrinks by a few per cent per iteration
//! (truss QPs stalled at 2e-6 and were sent to the elastic mode, whose weights steering then
//! drove to 1e12); the rows hold to 1e-5 and the SQP measures the true violation anyway. Unboundedness: when
//! ‖d‖∞ exceeds 10⁸ times the data scale, the normalized d̂ is tested as a direction of
//! recession with `gᵀd̂ < 0` and `d̂ᵀH d̂ ≈ 0`.
//!
//! Indefinite H is convexified first (`newton.rs`: IPOPT-style inertia correction, after a flip
//! of negative diagonal entries, see `convexification.rs`); the diagonal E actually added is
//! reported in [`SparseQpInfo::convexification`] — the QP solved is then the one with H + E.
//!
//! Use from an SQP: keep one [`SparseQp`] for the whole NLP solve and call
//! [`SparseQp::solve`] each major iteration; the symbolic analysis is redone only when the
//! sparsity of H or A changes (bound values and the infinite/finite/fixed pattern of the bounds
//! may change freely); a solver that is dropped leaves its Newton system to the next solver of
//! the same pattern on its thread (`kept.rs`: the same steps, bit for bit, without rebuilding
//! the system). There is no warm start: an interior-point method starts from its own
//! interior point (d = 0 pushed at least min(1, ¼ width) inside finite bounds), and typically
//! needs 10–30 iterations whatever the previous working set was. On `Infeasible` the returned
//! d is the last iterate (not a least-infeasible point): an elastic QP must be solved instead.
//! On `Numerical` and `IterationLimit` the last finite iterate is returned.
//!
//! Interrupt: [`SparseQp::interrupt`] is polled before the convexification and before each
//! iteration, so a raised flag ends the solve with [`QpStatus::Interrupted`] (the last iterate)
//! within one iteration: one factorization of the Newton matrix and its refined solves.

mod certificates;
mod convexification;
mod kept;
mod layout;
mod newton;
mod operators;
mod step;
#[cfg(test)]
mod tests;

use certificates::{
    breakdown_status, converged_except_feasibility, infeasibility_certified, unboundedness_detected,
};
pub use convexification::Convexification;
use layout::{Layout, RowKind, is_finite_bound};
use newton::NewtonSystem;
use operators::{a_times, a_transpose_times, dot, hessian_times, inf_norm};
use step::iterate;

use super::{QpHessian, QpProblem, QpSolution, QpStatus};
use crate::solver::Interrupt;

/// Iterations over which a primal residual that fails to halve counts as stalled.
const STALL_WINDOW: usize = 5;
/// Relative primal residual below which a stalled iterate that has converged except for
/// feasibility ends `Optimal` rather than `Infeasible` (module header).
const NEAR_FEASIBLE: f64 = 1e-5;

/// Default first convexification shift (relative), see [`SparseQp::first_shift`].
pub const DEFAULT_FIRST_SHIFT: f64 = 1e-4;

/// Default growth of the convexification shift between trials, see [`SparseQp::shift_growth`].
pub const DEFAULT_SHIFT_GROWTH: f64 = 10.0;

/// Default iteration limit.
pub const DEFAULT_MAX_ITERATIONS: usize = 200;

/// What one solve did besides the [`QpSolution`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SparseQpInfo {
    /// The diagonal added to H to make the QP convex (zero when H already was).
    pub convexification: Convexification,
    /// Numeric KKT factorizations performed (convexification trials included).
    pub factorizations: usize,
    /// True when the symbolic analysis of the previous solve was reused.
    pub reused_symbolic: bool,
    /// Final relative primal residual.
    pub primal_residual: f64,
    /// Final relative dual residual.
    pub dual_residual: f64,
    /// Final relative complementarity tᵀz / (1 + |objective|).
    pub complementarity: f64,
}

/// Solves one QP with a fresh workspace. `tolerance` is the relative KKT tolerance ε of the
/// module header (e.g. 1e-8). The sparse [`QpHessian::SparseLower`] form may be indefinite.
///
/// ```
/// use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};
/// use optimize::solver::qp::{QpHessian, QpProblem, QpStatus, sparse};
///
/// // min ½(d₀² + d₁²) − 2d₀  s.t.  d₀ + d₁ = 1,  d ≥ 0:  d = (1, 0), λ = 1, z = (0, −1).
/// let h = CscMatrix::identity(2);
/// let a = CsrMatrix::from(&CooMatrix::try_from_triplets(1, 2, vec![0, 0], vec![0, 1], vec![1.0, 1.0]).unwrap());
/// let inf = f64::INFINITY;
/// let qp = QpProblem {
///     h: QpHessian::SparseLower(&h),
///     g: &[-2.0, 0.0],
///     a: &a,
///     dl: &[0.0, 0.0],
///     du: &[inf, inf],
///     bl: &[1.0],
///     bu: &[1.0],
/// };
/// let sol = sparse::solve(&qp, 1e-10);
/// assert_eq!(sol.status, QpStatus::Optimal);
/// assert!((sol.d[0] - 1.0).abs() < 1e-8 && sol.d[1].abs() < 1e-8);
/// assert!((sol.lambda[0] - 1.0).abs() < 1e-8 && (sol.z[1] + 1.0).abs() < 1e-8);
/// ```
pub fn solve(problem: &QpProblem<'_>, tolerance: f64) -> QpSolution {
    SparseQp::new().solve(problem, tolerance).0
}

/// A reusable solver: keeps the symbolic analysis across QPs with the same sparsity pattern
/// (as successive SQP subproblems have) and all iteration workspaces.
pub struct SparseQp {
    /// Iteration limit.
    pub max_iterations: usize,
    /// First nonzero convexification shift tried, relative to `max(1, maxⱼ|Hⱼⱼ|)`
    /// ([`DEFAULT_FIRST_SHIFT`], IPOPT's 1e-4); later trials grow by [`SparseQp::shift_growth`].
    /// An SQP without barrier curvature wants 1 (a singular H must not give steps of length
    /// ‖g‖/δ).
    pub first_shift: f64,
    /// Factor between successive convexification trials ([`DEFAULT_SHIFT_GROWTH`]).
    pub shift_growth: f64,
    /// When set, the convexification used without an inertia search (the caller knows it
    /// suffices, e.g. the QP has more equality rows than one already convexified with it).
    pub fixed_convexification: Option<Convexification>,
    /// When set, H must pass the inertia test as it is (no convexification): a QP that would
    /// need one ends [`QpStatus::Numerical`] after that one factorization (an SQP's Newton
    /// step on an identified active set, taken only when it needs no correction).
    pub exact_only: bool,
    /// Smallest shift δ_c tried (absolute, default 0): an SQP damps its steps with it when
    /// the exact Hessian's Newton steps were much longer than its line search could accept.
    pub min_shift: f64,
    /// The run's interrupt flag (module header); a fresh solver's is never raised.
    pub interrupt: Interrupt,
    system: Option<NewtonSystem>,
    layout: Layout,
    ws: Workspace,
}

impl Drop for SparseQp {
    /// Leaves the Newton system to the next solver of its pattern on this thread (`kept`).
    fn drop(&mut self) {
        if let Some(system) = self.system.take() {
            kept::keep(system);
        }
    }
}

impl Default for SparseQp {
    fn default() -> Self {
        Self::new()
    }
}

/// Primal-dual variables (or a direction in them).
#[derive(Default)]
struct Point {
    d: Vec<f64>,
    s: Vec<f64>,
    y: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    wl: Vec<f64>,
    wu: Vec<f64>,
}

impl Point {
    fn copy_from(&mut self, other: &Point) {
        self.d.copy_from_slice(&other.d);
        self.s.copy_from_slice(&other.s);
        self.y.copy_from_slice(&other.y);
        self.zl.copy_from_slice(&other.zl);
        self.zu.copy_from_slice(&other.zu);
        self.wl.copy_from_slice(&other.wl);
        self.wu.copy_from_slice(&other.wu);
    }

    fn resize(&mut self, n: usize, m: usize) {
        for v in [&mut self.d, &mut self.zl, &mut self.zu] {
            v.clear();
            v.resize(n, 0.0);
        }
        for v in [&mut self.s, &mut self.y, &mut self.wl, &mut self.wu] {
            v.clear();
            v.resize(m, 0.0);
        }
    }
}

/// Everything an iteration touches, allocated once per problem size.
#[derive(Default)]
struct Workspace {
    x: Point,
    backup: Point,
    dir: Point,
    aff: Point,
    hd: Vec<f64>,
    aty: Vec<f64>,
    ad: Vec<f64>,
    rd: Vec<f64>,
    rp: Vec<f64>,
    rs: Vec<f64>,
    sig_d: Vec<f64>,
    /// The convexification's diagonal, per variable.
    added: Vec<f64>,
    sig_s: Vec<f64>,
    dual_diag: Vec<f64>,
    rcl: Vec<f64>,
    rcu: Vec<f64>,
    rcwl: Vec<f64>,
    rcwu: Vec<f64>,
    rhs: Vec<f64>,
    tmp: Vec<f64>,
}

impl Workspace {
    fn resize(&mut self, n: usize, m: usize, p: usize) {
        self.x.resize(n, m);
        self.backup.resize(n, m);
        self.dir.resize(n, m);
        self.aff.resize(n, m);
        for v in [
            &mut self.hd,
            &mut self.aty,
            &mut self.rd,
            &mut self.sig_d,
            &mut self.added,
            &mut self.rcl,
            &mut self.rcu,
        ] {
            v.clear();
            v.resize(n, 0.0);
        }
        for v in [
            &mut self.ad,
            &mut self.rp,
            &mut self.rs,
            &mut self.sig_s,
            &mut self.dual_diag,
            &mut self.rcwl,
            &mut self.rcwu,
        ] {
            v.clear();
            v.resize(m, 0.0);
        }
        self.rhs.clear();
        self.rhs.resize(n + m, 0.0);
        self.tmp.clear();
        self.tmp.resize(2 * p, 0.0);
    }
}

/// Convergence measures of the current iterate.
#[derive(Debug, Clone, Copy)]
struct Measures {
    primal: f64,
    dual: f64,
    gap: f64,
    mu: f64,
}

impl SparseQp {
    /// An empty solver; buffers grow on the first solve.
    pub fn new() -> Self {
        SparseQp {
            max_iterations: DEFAULT_MAX_ITERATIONS,
            first_shift: DEFAULT_FIRST_SHIFT,
            shift_growth: DEFAULT_SHIFT_GROWTH,
            fixed_convexification: None,
            exact_only: false,
            min_shift: 0.0,
            interrupt: Interrupt::new(),
            system: None,
            layout: Layout::default(),
            ws: Workspace::default(),
        }
    }

    /// The status of a QP that needs no interior-point iteration (the step d = 0 is returned):
    /// mismatched dimensions, a raised interrupt, contradictory bounds, or no variables (A d = 0
    /// either satisfies every row or none can). Classifies the rows into `self.layout`.
    fn settled_without_iterating(&mut self, qp: &QpProblem<'_>) -> Option<QpStatus> {
        if !dimensions_agree(qp) {
            return Some(QpStatus::Numerical);
        }
        if self.interrupt.is_raised() {
            return Some(QpStatus::Interrupted);
        }
        if self.layout.classify(qp).is_err() {
            return Some(QpStatus::Infeasible);
        }
        if qp.g.is_empty() {
            let feasible = (0..qp.a.nrows()).all(|i| qp.bl[i] <= 0.0 && 0.0 <= qp.bu[i]);
            return Some(if feasible {
                QpStatus::Optimal
            } else {
                QpStatus::Infeasible
            });
        }
        None
    }

    /// Solves `problem` to relative tolerance `tolerance`; see the module header.
    pub fn solve(&mut self, qp: &QpProblem<'_>, tolerance: f64) -> (QpSolution, SparseQpInfo) {
        let (n, m) = (qp.g.len(), qp.a.nrows());
        let mut info = SparseQpInfo::default();
        let fail = |status| QpSolution {
            status,
            d: vec![0.0; n],
            lambda: vec![0.0; m],
            z: vec![0.0; n],
            iterations: 0,
        };
        if let Some(status) = self.settled_without_iterating(qp) {
            return (fail(status), info);
        }
        info.reused_symbolic = self.system.as_ref().is_some_and(|s| s.matches(qp));
        if !info.reused_symbolic {
            if let Some(other) = self.system.take() {
                kept::keep(other);
            }
            match kept::take(qp).map_or_else(|| NewtonSystem::new(qp), Ok) {
                Ok(system) => self.system = Some(system),
                Err(_) => return (fail(QpStatus::Numerical), info),
            }
        }
        let Some(system) = self.system.as_mut() else {
            return (fail(QpStatus::Numerical), info);
        };
        let factorizations_before = system.factorizations();
        let p = match qp.h {
            QpHessian::LowRank { w, .. } => w.ncols(),
            _ => 0,
        };
        let ws = &mut self.ws;
        let layout = &self.layout;
        ws.resize(n, m, p);
        let convexification = match &self.fixed_convexification {
            Some(fixed) => fixed.clone(),
            None if self.exact_only => {
                let exact = Convexification::default();
                match system.passes(qp, layout, &exact, &mut ws.sig_d, &mut ws.dual_diag) {
                    Ok(true) => exact,
                    _ => return (fail(QpStatus::Numerical), info),
                }
            }
            None => match system.convexify(
                qp,
                layout,
                self.min_shift,
                self.first_shift,
                self.shift_growth,
                &mut ws.sig_d,
                &mut ws.dual_diag,
            ) {
                Ok(Some(convexification)) => convexification,
                _ => return (fail(QpStatus::Numerical), info),
            },
        };
        for (j, added) in ws.added.iter_mut().enumerate() {
            *added = convexification.added(j);
        }
        info.convexification = convexification;
        // Without complementarity pairs the Newton matrix is the one whose inertia was just
        // tested (H + δI with the equality rows): its factors, with the inertia test's dual
        // regularization, serve the step, refined against the same unregularized matrix.
        system.strong_step = self.fixed_convexification.is_none()
            && layout.pairs == 0
            && !matches!(qp.h, QpHessian::LowRank { .. });
        initial_point(qp, layout, ws);
        let mut status = QpStatus::IterationLimit;
        let mut iterations = 0;
        // Relative primal residuals of the last STALL_WINDOW + 1 iterations (ring buffer).
        let mut primal_history = [f64::INFINITY; STALL_WINDOW + 1];
        let mut previous: Option<Measures> = None;
        let mut stalled = false;
        while iterations <= self.max_iterations {
            let measures = residuals(qp, layout, ws);
            if !(measures.primal.is_finite()
                && measures.dual.is_finite()
                && measures.gap.is_finite())
            {
                // Return the last finite iterate (slacks rounding to zero end here).
                std::mem::swap(&mut ws.x, &mut ws.backup);
                residuals(qp, layout, ws);
                status = breakdown_status(previous, stalled, tolerance, NEAR_FEASIBLE);
                break;
            }
            info.primal_residual = measures.primal;
            info.dual_residual = measures.dual;
            info.complementarity = measures.gap;
            if measures.primal <= tolerance
                && measures.dual <= tolerance
                && measures.gap <= tolerance
            {
                status = QpStatus::Optimal;
                break;
            }
            primal_history[iterations % (STALL_WINDOW + 1)] = measures.primal;
            let window_start = primal_history[(iterations + 1) % (STALL_WINDOW + 1)];
            stalled = iterations >= STALL_WINDOW && measures.primal > 0.5 * window_start;
            let least_infeasible = stalled && converged_except_feasibility(measures, tolerance);
            if least_infeasible && measures.primal <= NEAR_FEASIBLE {
                status = QpStatus::Optimal;
                break;
            }
            if measures.primal > tolerance
                && (infeasibility_certified(qp, layout, ws) || least_infeasible)
            {
                status = QpStatus::Infeasible;
                break;
            }
            if unboundedness_detected(qp, layout, ws) {
                status = QpStatus::Unbounded;
                break;
            }
            if iterations == self.max_iterations {
                break;
            }
            if self.interrupt.is_raised() {
                status = QpStatus::Interrupted;
                break;
            }
            iterations += 1;
            previous = Some(measures);
            ws.backup.copy_from(&ws.x);
            if iterate(
                qp,
                layout,
                ws,
                system,
                measures.mu,
                measures.primal <= tolerance && measures.dual <= tolerance,
            )
            .is_err()
            {
                status = breakdown_status(previous, stalled, tolerance, NEAR_FEASIBLE);
                break;
            }
        }
        info.factorizations = system.factorizations() - factorizations_before;
        (solution(qp, layout, ws, status, iterations), info)
    }
}

fn dimensions_agree(qp: &QpProblem<'_>) -> bool {
    let (n, m) = (qp.g.len(), qp.a.nrows());
    let h_ok = match qp.h {
        QpHessian::Dense(h) => h.nrows() == n && h.ncols() == n,
        QpHessian::SparseLower(h) => h.nrows() == n && h.ncols() == n,
        QpHessian::LowRank { w, m: mm, .. } => {
            w.nrows() == n && mm.nrows() == w.ncols() && mm.ncols() == w.ncols()
        }
    };
    h_ok && qp.a.ncols() == n
        && qp.dl.len() == n
        && qp.du.len() == n
        && qp.bl.len() == m
        && qp.bu.len() == m
}

/// Interior value inside [l, u] at least `margin` (shrunk for narrow intervals) from each
/// finite bound, as close to `v` as possible.
fn push_inside(v: f64, l: f64, u: f64) -> f64 {
    let (has_l, has_u) = (is_finite_bound(l), is_finite_bound(u));
    let margin = if has_l && has_u {
        (0.25 * (u - l)).min(1.0)
    } else {
        1.0
    };
    let mut v = v;
    if has_l {
        v = v.max(l + margin);
    }
    if has_u {
        v = v.min(u - margin);
    }
    v
}

fn initial_point(qp: &QpProblem<'_>, layout: &Layout, ws: &mut Workspace) {
    let x = &mut ws.x;
    for j in 0..qp.g.len() {
        x.d[j] = if layout.fixed[j] {
            qp.dl[j]
        } else {
            push_inside(0.0, qp.dl[j], qp.du[j])
        };
        x.zl[j] = if layout.var_lower[j] { 1.0 } else { 0.0 };
        x.zu[j] = if layout.var_upper[j] { 1.0 } else { 0.0 };
    }
    a_times(qp.a, &x.d, &mut ws.ad);
    for i in 0..qp.a.nrows() {
        x.s[i] = if layout.row[i] == RowKind::Inequality {
            push_inside(ws.ad[i], qp.bl[i], qp.bu[i])
        } else {
            ws.ad[i]
        };
        x.wl[i] = if layout.row_lower[i] { 1.0 } else { 0.0 };
        x.wu[i] = if layout.row_upper[i] { 1.0 } else { 0.0 };
        x.y[i] = x.wu[i] - x.wl[i];
    }
}

/// Computes the residuals into the workspace and returns the relative measures.
fn residuals(qp: &QpProblem<'_>, layout: &Layout, ws: &mut Workspace) -> Measures {
    let x = &ws.x;
    hessian_times(&qp.h, &x.d, &mut ws.hd, &mut ws.tmp);
    for ((hd, d), added) in ws.hd.iter_mut().zip(&x.d).zip(&ws.added) {
        *hd += added * d;
    }
    a_transpose_times(qp.a, &x.y, &mut ws.aty);
    a_times(qp.a, &x.d, &mut ws.ad);
    let mut dual_scale = inf_norm(qp.g);
    for j in 0..qp.g.len() {
        ws.rd[j] = if layout.fixed[j] {
            0.0
        } else {
            dual_scale = dual_scale.max(ws.hd[j].abs()).max(ws.aty[j].abs());
            dual_scale = dual_scale.max(x.zl[j]).max(x.zu[j]);
            ws.hd[j] + qp.g[j] + ws.aty[j] - x.zl[j] + x.zu[j]
        };
    }
    // Row-wise relative primal residual, so that one large row does not mask another.
    let mut primal = 0.0f64;
    let mut gap = 0.0;
    for i in 0..qp.a.nrows() {
        ws.rs[i] = 0.0;
        ws.rp[i] = match layout.row[i] {
            RowKind::Free => 0.0,
            RowKind::Equality => ws.ad[i] - qp.bl[i],
            RowKind::Inequality => {
                ws.rs[i] = -x.y[i] - x.wl[i] + x.wu[i];
                if layout.row_lower[i] {
                    gap += (x.s[i] - qp.bl[i]) * x.wl[i];
                }
                if layout.row_upper[i] {
                    gap += (qp.bu[i] - x.s[i]) * x.wu[i];
                }
                ws.ad[i] - x.s[i]
            }
        };
        let target = if layout.row[i] == RowKind::Equality {
            qp.bl[i]
        } else {
            x.s[i]
        };
        primal = primal.max(ws.rp[i].abs() / (1.0 + ws.ad[i].abs().max(target.abs())));
    }
    for j in 0..qp.g.len() {
        if layout.var_lower[j] {
            gap += (x.d[j] - qp.dl[j]) * x.zl[j];
        }
        if layout.var_upper[j] {
            gap += (qp.du[j] - x.d[j]) * x.zu[j];
        }
    }
    let objective = 0.5 * dot(&x.d, &ws.hd) + dot(qp.g, &x.d);
    Measures {
        primal,
        dual: inf_norm(&ws.rd) / (1.0 + dual_scale),
        gap: gap / (1.0 + objective.abs()),
        mu: if layout.pairs > 0 {
            gap / layout.pairs as f64
        } else {
            0.0
        },
    }
}

/// Packs the iterate into a [`QpSolution`] with the shared sign convention.
fn solution(
    qp: &QpProblem<'_>,
    layout: &Layout,
    ws: &Workspace,
    status: QpStatus,
    iterations: usize,
) -> QpSolution {
    let x = &ws.x;
    let z = (0..qp.g.len())
        .map(|j| {
            if layout.fixed[j] {
                // Free multiplier of d_j = dl_j: closes the stationarity row exactly.
                -(ws.hd[j] + qp.g[j] + ws.aty[j])
            } else {
                x.zu[j] - x.zl[j]
            }
        })
        .collect();
    QpSolution {
        status,
        d: x.d.clone(),
        lambda: x.y.clone(),
        z,
        iterations,
    }
}
