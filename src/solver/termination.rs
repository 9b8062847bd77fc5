//! Scaled KKT measures for the termination tests (after IPOPT, Wächter & Biegler 2006, §2.1).
//!
//! With the scaled Lagrangian `L = f̃ + λ̃ᵀc̃ + zᵀx`:
//! - primal: `maxᵢ violᵢ / max(1, |active bound|ᵢ)` on the unscaled constraints (bounds on x
//!   hold exactly at every iterate), so a constraint with right-hand side 0 is held to the
//!   absolute tolerance;
//! - dual: `‖∇f̃ + J̃ᵀλ̃ + z‖∞ / s_d` where z is the least-squares bound multiplier for the
//!   bounds x sits on, and `s_d = min(S_D_MAX, max(100, (‖λ̃‖₁ + ‖z‖₁)/(m+n))/100)`: IPOPT's
//!   scaling, capped so that multipliers diverging towards a point without KKT multipliers
//!   (a cusp, as in HS13) cannot make any residual look small;
//! - complementarity: `maxᵢ |λ̃ᵢ|·|c̃ᵢ − bound| / s_d` over the side λ̃ᵢ's sign selects.

use nalgebra_sparse::CsrMatrix;

use super::merit::row_violation;

/// Largest divisor of the dual residual from the multiplier size.
const S_D_MAX: f64 = 100.0;

/// The measures at one point.
#[derive(Debug, Clone, Copy)]
pub struct Kkt {
    /// Relative primal infeasibility.
    pub primal: f64,
    /// Scaled dual residual and complementarity (the larger).
    pub optimality: f64,
}

/// Inputs of [`measure`], all scaled.
pub struct KktInput<'a> {
    /// Point.
    pub x: &'a [f64],
    /// Variable bounds.
    pub xl: &'a [f64],
    /// Variable bounds.
    pub xu: &'a [f64],
    /// Scaled constraint values.
    pub c: &'a [f64],
    /// Scaled constraint bounds.
    pub cl: &'a [f64],
    /// Scaled constraint bounds.
    pub cu: &'a [f64],
    /// Constraint scales.
    pub scale_c: &'a [f64],
    /// Scaled objective gradient.
    pub grad: &'a [f64],
    /// Scaled Jacobian.
    pub jac: &'a CsrMatrix<f64>,
    /// Scaled multipliers.
    pub lambda: &'a [f64],
}

/// Whether x sits on bound b (bounds are enforced exactly; this allows for rounding only).
fn on_bound(x: f64, b: f64) -> bool {
    b.is_finite() && (x - b).abs() <= 1e-12 * (1.0 + b.abs())
}

/// Computes the measures and the bound multipliers z (scaled).
pub fn measure(k: &KktInput) -> (Kkt, Vec<f64>) {
    let n = k.x.len();
    let m = k.c.len();
    let mut primal = 0.0_f64;
    for i in 0..m {
        let v = row_violation(k.c[i], k.cl[i], k.cu[i]);
        if v > 0.0 {
            let bound = if k.c[i] < k.cl[i] { k.cl[i] } else { k.cu[i] };
            primal = primal.max(v / k.scale_c[i].max(bound.abs()));
        }
    }
    let mut r = k.grad.to_vec();
    for (row, lane) in k.jac.row_iter().enumerate() {
        let l = k.lambda[row];
        if l != 0.0 {
            for (&j, &v) in lane.col_indices().iter().zip(lane.values()) {
                r[j] += l * v;
            }
        }
    }
    let mut z = vec![0.0; n];
    for j in 0..n {
        if (on_bound(k.x[j], k.xl[j]) && r[j] > 0.0) || (on_bound(k.x[j], k.xu[j]) && r[j] < 0.0) {
            z[j] = -r[j];
        }
    }
    let dual = r
        .iter()
        .zip(&z)
        .fold(0.0_f64, |a, (ri, zi)| a.max((ri + zi).abs()));
    let mut comp = 0.0_f64;
    for i in 0..m {
        let l = k.lambda[i];
        let gap = if l < 0.0 {
            k.c[i] - k.cl[i]
        } else if l > 0.0 {
            k.cu[i] - k.c[i]
        } else {
            0.0
        };
        let gap = if gap.is_finite() { gap.abs() } else { 1.0 };
        comp = comp.max(l.abs() * gap);
    }
    let l1: f64 =
        k.lambda.iter().map(|v| v.abs()).sum::<f64>() + z.iter().map(|v| v.abs()).sum::<f64>();
    let s_d = ((l1 / ((n + m).max(1) as f64)).max(100.0) / 100.0).min(S_D_MAX);
    (
        Kkt {
            primal,
            optimality: dual.max(comp) / s_d,
        },
        z,
    )
}
