//! One Mehrotra predictor–corrector step of the interior-point QP method.
//!
//! ```text
//!     predictor:  complementarity target 0            → Δ_aff, α_aff, μ_aff
//!     centring:   σ = (μ_aff / μ)³
//!     corrector:  target σμ − Δt_aff ∘ Δz_aff          → Δ, α = 0.995 min(1, α_max) (1 without pairs)
//! ```
//! Safeguard: Mehrotra's heuristic has no convergence guarantee, and on a degenerate QP its
//! corrector can cycle (a truss member's tension and compression parts, one at its bound in
//! turn: the complementarity rose and fell with period 4 for 200 iterations while the primal and
//! dual residuals stayed at 1e-15). When, at a primal and dual feasible iterate, the corrector
//! step would raise the average complementarity μ, the step is recomputed as a plain centred Newton step (σ = ½, no
//! second-order term), whose complementarity decreases to first order.
//!
//! Both solves reuse one factorization of the Newton matrix (`newton.rs`); primal and dual
//! variables take the common step α. Slacks t of the bounds are recomputed from d and s
//! (t = d − dl, …), so the bound equations hold exactly at every iterate.

use super::layout::{Layout, RowKind};
use super::newton::NewtonSystem;
use super::{Point, Workspace};
use crate::solver::kkt::KktError;
use crate::solver::qp::QpProblem;

/// Fraction of the distance to the boundary taken by a step.
const STEP_TO_BOUNDARY: f64 = 0.995;

/// Centring parameter σ of the safeguarded step (module header).
const SAFEGUARD_CENTRING: f64 = 0.5;

/// One predictor–corrector iteration; `feasible` when the primal and dual residuals are within
/// the tolerance (the safeguard of the module header applies only then: away from
/// feasibility μ may rightly grow, and infeasibility certificates need those steps).
pub(super) fn iterate(
    qp: &QpProblem<'_>,
    layout: &Layout,
    ws: &mut Workspace,
    system: &mut NewtonSystem,
    mu: f64,
    feasible: bool,
) -> Result<(), KktError> {
    let (n, m) = (qp.g.len(), qp.a.nrows());
    // Barrier Hessian terms.
    for j in 0..n {
        let x = &ws.x;
        let mut sigma = ws.added[j];
        if layout.var_lower[j] {
            sigma += x.zl[j] / (x.d[j] - qp.dl[j]);
        }
        if layout.var_upper[j] {
            sigma += x.zu[j] / (qp.du[j] - x.d[j]);
        }
        ws.sig_d[j] = sigma;
    }
    for i in 0..m {
        let x = &ws.x;
        let mut sigma = 0.0;
        if layout.row_lower[i] {
            sigma += x.wl[i] / (x.s[i] - qp.bl[i]);
        }
        if layout.row_upper[i] {
            sigma += x.wu[i] / (qp.bu[i] - x.s[i]);
        }
        ws.sig_s[i] = sigma;
        ws.dual_diag[i] = match layout.row[i] {
            RowKind::Free => -1.0,
            RowKind::Equality => 0.0,
            RowKind::Inequality => -1.0 / sigma,
        };
    }
    system.assemble(qp, layout, &ws.sig_d, |_| true, &ws.dual_diag);
    system.factor(qp, layout)?;

    // Predictor (affine scaling): complementarity target 0.
    complementarity_targets(qp, layout, ws, 0.0, false);
    direction(qp, layout, ws, system)?;
    std::mem::swap(&mut ws.aff, &mut ws.dir);
    let alpha_aff = max_step(qp, layout, &ws.x, &ws.aff).min(1.0);
    let sigma = if layout.pairs > 0 && mu > 0.0 {
        let mu_aff =
            complementarity_after(qp, layout, &ws.x, &ws.aff, alpha_aff) / layout.pairs as f64;
        (mu_aff / mu).clamp(0.0, 1.0).powi(3)
    } else {
        0.0
    };
    let alpha = if layout.pairs == 0 {
        // Without complementarity pairs the corrector's right-hand side is the predictor's,
        // and nothing limits the step: the full Newton step solves a QP without bounds or
        // inequality rows.
        std::mem::swap(&mut ws.aff, &mut ws.dir);
        1.0
    } else {
        // Corrector: centring plus the second-order term of the predictor.
        complementarity_targets(qp, layout, ws, sigma * mu, true);
        direction(qp, layout, ws, system)?;
        let alpha = STEP_TO_BOUNDARY * max_step(qp, layout, &ws.x, &ws.dir).min(1.0);
        let pairs = layout.pairs as f64;
        if feasible && complementarity_after(qp, layout, &ws.x, &ws.dir, alpha) / pairs > mu {
            // Mehrotra's corrector raised the complementarity: a centred step without the
            // second-order term instead (see the module header).
            complementarity_targets(qp, layout, ws, SAFEGUARD_CENTRING * mu, false);
            direction(qp, layout, ws, system)?;
            STEP_TO_BOUNDARY * max_step(qp, layout, &ws.x, &ws.dir).min(1.0)
        } else {
            alpha
        }
    };
    let (x, dir) = (&mut ws.x, &ws.dir);
    for (a, b) in [
        (&mut x.d, &dir.d),
        (&mut x.s, &dir.s),
        (&mut x.y, &dir.y),
        (&mut x.zl, &dir.zl),
        (&mut x.zu, &dir.zu),
        (&mut x.wl, &dir.wl),
        (&mut x.wu, &dir.wu),
    ] {
        for (ai, bi) in a.iter_mut().zip(b.iter()) {
            *ai += alpha * bi;
        }
    }
    Ok(())
}

/// Complementarity right-hand sides `target − t∘z (− Δt_aff∘Δz_aff when corrected)`.
fn complementarity_targets(
    qp: &QpProblem<'_>,
    layout: &Layout,
    ws: &mut Workspace,
    target: f64,
    corrected: bool,
) {
    let (x, aff) = (&ws.x, &ws.aff);
    let c = if corrected { 1.0 } else { 0.0 };
    for j in 0..qp.g.len() {
        ws.rcl[j] = if layout.var_lower[j] {
            target - (x.d[j] - qp.dl[j]) * x.zl[j] - c * aff.d[j] * aff.zl[j]
        } else {
            0.0
        };
        ws.rcu[j] = if layout.var_upper[j] {
            target - (qp.du[j] - x.d[j]) * x.zu[j] + c * aff.d[j] * aff.zu[j]
        } else {
            0.0
        };
    }
    for i in 0..qp.a.nrows() {
        ws.rcwl[i] = if layout.row_lower[i] {
            target - (x.s[i] - qp.bl[i]) * x.wl[i] - c * aff.s[i] * aff.wl[i]
        } else {
            0.0
        };
        ws.rcwu[i] = if layout.row_upper[i] {
            target - (qp.bu[i] - x.s[i]) * x.wu[i] + c * aff.s[i] * aff.wu[i]
        } else {
            0.0
        };
    }
}

/// Solves the Newton system for the current complementarity targets into `ws.dir`.
fn direction(
    qp: &QpProblem<'_>,
    layout: &Layout,
    ws: &mut Workspace,
    system: &mut NewtonSystem,
) -> Result<(), KktError> {
    let (n, m) = (qp.g.len(), qp.a.nrows());
    let x = &ws.x;
    for j in 0..n {
        ws.rhs[j] = if layout.fixed[j] {
            0.0
        } else {
            let mut rho = -ws.rd[j];
            if layout.var_lower[j] {
                rho += ws.rcl[j] / (x.d[j] - qp.dl[j]);
            }
            if layout.var_upper[j] {
                rho -= ws.rcu[j] / (qp.du[j] - x.d[j]);
            }
            rho
        };
    }
    for i in 0..m {
        ws.rhs[n + i] = match layout.row[i] {
            RowKind::Free => 0.0,
            RowKind::Equality => -ws.rp[i],
            RowKind::Inequality => -ws.rp[i] + slack_rho(qp, layout, ws, i) / ws.sig_s[i],
        };
    }
    system.solve(qp, &mut ws.rhs)?;
    let x = &ws.x;
    let dir = &mut ws.dir;
    dir.d.copy_from_slice(&ws.rhs[..n]);
    dir.y.copy_from_slice(&ws.rhs[n..]);
    for j in 0..n {
        dir.zl[j] = if layout.var_lower[j] {
            (ws.rcl[j] - x.zl[j] * dir.d[j]) / (x.d[j] - qp.dl[j])
        } else {
            0.0
        };
        dir.zu[j] = if layout.var_upper[j] {
            (ws.rcu[j] + x.zu[j] * dir.d[j]) / (qp.du[j] - x.d[j])
        } else {
            0.0
        };
    }
    for i in 0..m {
        if layout.row[i] != RowKind::Inequality {
            let dir = &mut ws.dir;
            dir.s[i] = 0.0;
            dir.wl[i] = 0.0;
            dir.wu[i] = 0.0;
            continue;
        }
        let ds = (slack_rho(qp, layout, ws, i) + ws.rhs[n + i]) / ws.sig_s[i];
        let (x, dir) = (&ws.x, &mut ws.dir);
        dir.s[i] = ds;
        dir.wl[i] = if layout.row_lower[i] {
            (ws.rcwl[i] - x.wl[i] * ds) / (x.s[i] - qp.bl[i])
        } else {
            0.0
        };
        dir.wu[i] = if layout.row_upper[i] {
            (ws.rcwu[i] + x.wu[i] * ds) / (qp.bu[i] - x.s[i])
        } else {
            0.0
        };
    }
    Ok(())
}

/// ρ_s of inequality row i: `−r_s + rcw_l/u_l − rcw_u/u_u`.
fn slack_rho(qp: &QpProblem<'_>, layout: &Layout, ws: &Workspace, i: usize) -> f64 {
    let x = &ws.x;
    let mut rho = -ws.rs[i];
    if layout.row_lower[i] {
        rho += ws.rcwl[i] / (x.s[i] - qp.bl[i]);
    }
    if layout.row_upper[i] {
        rho -= ws.rcwu[i] / (qp.bu[i] - x.s[i]);
    }
    rho
}

/// Largest α (∞ when nothing limits it) keeping every slack and multiplier nonnegative along
/// `dir`. The step taken is `0.995 min(1, α)`, or 1 for a QP without bounds or inequality
/// rows (no complementarity pairs), which one step then solves: 0.995 left 0.5 % of the
/// residual after every step, four iterations per QP.
fn max_step(qp: &QpProblem<'_>, layout: &Layout, x: &Point, dir: &Point) -> f64 {
    let mut alpha = f64::INFINITY;
    let mut limit = |value: f64, change: f64| {
        if change < 0.0 {
            alpha = alpha.min(-value / change);
        }
    };
    for j in 0..qp.g.len() {
        if layout.var_lower[j] {
            limit(x.d[j] - qp.dl[j], dir.d[j]);
            limit(x.zl[j], dir.zl[j]);
        }
        if layout.var_upper[j] {
            limit(qp.du[j] - x.d[j], -dir.d[j]);
            limit(x.zu[j], dir.zu[j]);
        }
    }
    for i in 0..qp.a.nrows() {
        if layout.row_lower[i] {
            limit(x.s[i] - qp.bl[i], dir.s[i]);
            limit(x.wl[i], dir.wl[i]);
        }
        if layout.row_upper[i] {
            limit(qp.bu[i] - x.s[i], -dir.s[i]);
            limit(x.wu[i], dir.wu[i]);
        }
    }
    alpha
}

/// tᵀz after a step α along `dir`.
fn complementarity_after(
    qp: &QpProblem<'_>,
    layout: &Layout,
    x: &Point,
    dir: &Point,
    alpha: f64,
) -> f64 {
    let mut gap = 0.0;
    for j in 0..qp.g.len() {
        let d = x.d[j] + alpha * dir.d[j];
        if layout.var_lower[j] {
            gap += (d - qp.dl[j]) * (x.zl[j] + alpha * dir.zl[j]);
        }
        if layout.var_upper[j] {
            gap += (qp.du[j] - d) * (x.zu[j] + alpha * dir.zu[j]);
        }
    }
    for i in 0..qp.a.nrows() {
        let s = x.s[i] + alpha * dir.s[i];
        if layout.row_lower[i] {
            gap += (s - qp.bl[i]) * (x.wl[i] + alpha * dir.wl[i]);
        }
        if layout.row_upper[i] {
            gap += (qp.bu[i] - s) * (x.wu[i] + alpha * dir.wu[i]);
        }
    }
    gap
}
