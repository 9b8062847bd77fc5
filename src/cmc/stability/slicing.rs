//! Spectrum slicing: the smallest eigenvalues of a sparse symmetric K on the orthogonal
//! complement of a few orthonormal rows, from inertia counts (see the parent module).
//!
//! ```text
//!     count(σ) = ν₋([K − σI, Rᵀ; R, 0]) − b = #{λ of K on null(R) : λ < σ}
//!     λ_i = inf{σ : count(σ) ≥ i}, bracketed by bisection from the Gershgorin interval [−g, g]
//! ```
//! Every count is one sparse LDLᵀ factorization of the same pattern ([`super::bordered`]). A
//! bracket stops at twice the tolerance of its midpoint ([`super::tolerances`] with the midpoint
//! as its own scale); the midpoint is reported, half the width its error bound. The
//! fallback of [`super::shift_invert`], which needs two factorizations instead of dozens.

use nalgebra::DVector;

use super::bordered::{Bordered, gershgorin};
use super::{Spectrum, tolerances};
use crate::solver::kkt::KktError;

/// The `wanted` smallest eigenvalues of K (n×n, `entries` of both triangles) on the orthogonal
/// complement of the orthonormal `basis`, and how many lie below `−negative_tolerance·g`.
pub(super) fn smallest(
    n: usize,
    entries: &[(usize, usize, f64)],
    basis: &[DVector<f64>],
    wanted: usize,
    negative_tolerance: f64,
) -> Result<Spectrum, String> {
    let why = |e: KktError| format!("spectrum slicing failed: {e}");
    let g = gershgorin(n, entries);
    let mut bordered = Bordered::new(n, entries, basis).map_err(why)?;
    let free = n.saturating_sub(basis.len());
    let wanted = wanted.min(free);
    // Known counts (σ, count), ascending in σ; counts are non-decreasing in σ.
    let (low, high) = (-1.01 * g, 1.01 * g);
    let mut known = vec![(low, 0), (high, free)];
    let mut smallest = Vec::with_capacity(wanted);
    let mut errors = Vec::with_capacity(wanted);
    for i in 1..=wanted {
        // The bracket: the largest σ known with count < i, the smallest with count ≥ i.
        let mut lo = known
            .iter()
            .filter(|&&(_, c)| c < i)
            .fold(low, |m, &(s, _)| m.max(s));
        let mut hi = known
            .iter()
            .filter(|&&(_, c)| c >= i)
            .fold(high, |m, &(s, _)| m.min(s));
        while hi - lo > 2.0 * tolerances(&[0.5 * (lo + hi)], 1, g)[0] {
            let mid = 0.5 * (lo + hi);
            let c = bordered.count(mid).map_err(why)?;
            known.push((mid, c));
            if c >= i {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        smallest.push(0.5 * (lo + hi));
        errors.push(0.5 * (hi - lo));
    }
    let negative = bordered.count(-negative_tolerance * g).map_err(why)?;
    Ok(Spectrum {
        smallest,
        errors,
        negative,
    })
}
