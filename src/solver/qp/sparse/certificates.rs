//! Infeasibility and unboundedness tests of the interior-point QP method.
//!
//! ```text
//!     Farkas:      S = dlᵀz_l − duᵀz_u + blᵀw_l − buᵀw_u − b_Eᵀy_E,   R = ‖Aᵀy − z_l + z_u‖∞
//!                  every feasible d has S ≤ ‖d‖₁ R, so S > 10⁶(1 + ‖d_k‖₁) R ⇒ infeasible
//!     stall:       primal residual not halved over 5 iterations while dual residual ≤ ε and
//!                  complementarity ≤ primal residual ⇒ infeasible (least-infeasible limit)
//!     recession:   ‖d‖∞ ≫ data, d̂ = d/‖d‖∞ with gᵀd̂ < 0, d̂ᵀHd̂ ≈ 0, A d̂ and d̂ inside the
//!                  recession cones of the bounds ⇒ unbounded
//! ```
//! See the header of the parent module for the derivation of the Farkas bound.

use super::layout::{Layout, RowKind, is_finite_bound};
use super::operators::{dot, inf_norm};
use super::{Measures, Workspace};
use crate::solver::qp::{QpProblem, QpStatus};

/// Radius factor of the infeasibility certificate.
const CERTIFICATE_RADIUS: f64 = 1e6;
/// ‖d‖∞ relative to the data scale beyond which unboundedness is tested.
const DIVERGENCE: f64 = 1e8;

/// Dual feasibility and complementarity reached while the primal residual is larger than the
/// complementarity: the iterates approach a least-infeasible point, the signature of an
/// infeasible QP when the primal residual has also stopped decreasing.
pub(super) fn converged_except_feasibility(measures: Measures, tolerance: f64) -> bool {
    measures.primal > tolerance && measures.dual <= tolerance && measures.gap <= measures.primal
}

/// Status after a factorization breakdown or a non-finite iterate. The duals of an infeasible
/// QP diverge and its slacks shrink until they round to zero, so a breakdown after a dual
/// feasible iterate whose primal residual had converged except for feasibility, or had
/// stalled, means infeasible — unless that residual was below `near_feasible`, where the last
/// finite iterate is kept as the solution (the parent module's near-feasibility rule); anything
/// else is a numerical failure.
pub(super) fn breakdown_status(
    previous: Option<Measures>,
    stalled: bool,
    tolerance: f64,
    near_feasible: f64,
) -> QpStatus {
    match previous {
        Some(m)
            if m.primal > tolerance
                && m.dual <= tolerance
                && (stalled || converged_except_feasibility(m, tolerance)) =>
        {
            if m.primal <= near_feasible && m.gap <= tolerance {
                QpStatus::Optimal
            } else {
                QpStatus::Infeasible
            }
        }
        _ => QpStatus::Numerical,
    }
}

/// The Farkas test of the module header on the current dual iterate (uses `ws.aty`).
pub(super) fn infeasibility_certified(qp: &QpProblem<'_>, layout: &Layout, ws: &Workspace) -> bool {
    let x = &ws.x;
    let mut support = 0.0;
    let mut residual = 0.0f64;
    let mut d_norm1 = 0.0;
    for j in 0..qp.g.len() {
        d_norm1 += x.d[j].abs();
        if layout.fixed[j] {
            support += qp.dl[j] * ws.aty[j];
            continue;
        }
        if layout.var_lower[j] {
            support += qp.dl[j] * x.zl[j];
        }
        if layout.var_upper[j] {
            support -= qp.du[j] * x.zu[j];
        }
        residual = residual.max((ws.aty[j] - x.zl[j] + x.zu[j]).abs());
    }
    for i in 0..qp.a.nrows() {
        match layout.row[i] {
            RowKind::Free => {}
            RowKind::Equality => support -= qp.bl[i] * x.y[i],
            RowKind::Inequality => {
                if layout.row_lower[i] {
                    support += qp.bl[i] * x.wl[i];
                }
                if layout.row_upper[i] {
                    support -= qp.bu[i] * x.wu[i];
                }
            }
        }
    }
    support > 0.0 && support > CERTIFICATE_RADIUS * (1.0 + d_norm1) * residual
}

/// Tests whether the (diverging) iterate d points along a direction of unbounded descent.
pub(super) fn unboundedness_detected(qp: &QpProblem<'_>, layout: &Layout, ws: &Workspace) -> bool {
    let d = &ws.x.d;
    let norm = inf_norm(d);
    let mut scale = 1.0f64.max(inf_norm(qp.g));
    for v in qp.dl.iter().chain(qp.du).chain(qp.bl).chain(qp.bu) {
        if is_finite_bound(*v) {
            scale = scale.max(v.abs());
        }
    }
    if norm <= DIVERGENCE * scale {
        return false;
    }
    let slope = dot(qp.g, d) / norm;
    // ws.hd already includes the convexification shift.
    let curvature = dot(d, &ws.hd) / (norm * norm);
    let eps = 1e-6;
    if slope >= 0.0 || curvature > eps * slope.abs() {
        return false;
    }
    for (j, dj) in d.iter().enumerate() {
        let v = dj / norm;
        if layout.fixed[j] && v.abs() > eps
            || layout.var_lower[j] && v < -eps
            || layout.var_upper[j] && v > eps
        {
            return false;
        }
    }
    for i in 0..qp.a.nrows() {
        let v = ws.ad[i] / norm;
        let bad = match layout.row[i] {
            RowKind::Free => false,
            RowKind::Equality => v.abs() > eps,
            RowKind::Inequality => {
                layout.row_lower[i] && v < -eps || layout.row_upper[i] && v > eps
            }
        };
        if bad {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn measures(primal: f64) -> Measures {
        Measures {
            primal,
            dual: 1e-14,
            gap: 1e-12,
            mu: 1e-14,
        }
    }

    #[test]
    fn a_breakdown_near_feasibility_keeps_the_iterate_and_far_from_it_means_infeasible() {
        let tolerance = 1e-8;
        let near = breakdown_status(Some(measures(2e-8)), true, tolerance, 1e-5);
        assert_eq!(near, QpStatus::Optimal);
        let far = breakdown_status(Some(measures(1e-3)), true, tolerance, 1e-5);
        assert_eq!(far, QpStatus::Infeasible);
        let unconverged = Measures {
            dual: 1e-3,
            ..measures(2e-8)
        };
        let numerical = breakdown_status(Some(unconverged), true, tolerance, 1e-5);
        assert_eq!(numerical, QpStatus::Numerical);
    }
}
