//! Second-order models of the Lagrangian for the SQP subproblems.
//!
//! - [`DenseBfgs`]: dense damped BFGS (Powell 1978), for small n;
//! - [`Lbfgs`]: limited-memory BFGS in the compact form of Byrd, Nocedal & Schnabel (1994),
//!   `B = δI − W M Wᵀ`, never forming an n×n matrix;
//! - [`InertiaShift`]: the δ schedule that makes an exact Hessian positive definite
//!   (Wächter & Biegler 2006, §3.1), remembered between iterations;
//! - [`held_at_bounds`], [`decouple_dense`]: the variables held at a bound
//!   by their multiplier, taken out of that convexification (only the Hessian on the free
//!   variables must be positive definite, on the null space of the active rows).
//!
//! All work on the scaled Lagrangian `L = s_f·f + Σ λᵢ sᵢ cᵢ` of the SQP (unitless).

mod bfgs;
mod exact;
mod held;
mod lbfgs;
mod lower;
mod model;

pub use bfgs::DenseBfgs;
pub use exact::{Convexified, FALLBACK_GAMMA, InertiaShift, assemble_dense, scale_of};
pub use held::{decouple_dense, decouple_triplets, held_at_bounds};
pub use lbfgs::Lbfgs;
pub use lower::assemble_sparse_lower;
pub use model::Model;

/// Powell's damping: replaces y by `θy + (1−θ)Bs` when `sᵀy < 0.2 sᵀBs`, so that the update
/// keeps B positive definite. Returns the (possibly) damped y. `bs` is B·s, `sbs` is sᵀBs.
pub fn powell_damped(s: &[f64], y: &[f64], bs: &[f64], sbs: f64) -> Vec<f64> {
    let sy: f64 = s.iter().zip(y).map(|(a, b)| a * b).sum();
    if sy >= 0.2 * sbs {
        return y.to_vec();
    }
    let theta = 0.8 * sbs / (sbs - sy);
    y.iter()
        .zip(bs)
        .map(|(yi, bsi)| theta * yi + (1.0 - theta) * bsi)
        .collect()
}
