//! Shift-invert block Rayleigh–Ritz: the smallest eigenvalues of a sparse symmetric K on the
//! complement null(R) of a few orthonormal rows, from one factorization below the spectrum
//! (see the parent module).
//!
//! ```text
//!     σ < λ₁:  T = (P(K − σI)P)⁻¹ on null(R), applied by the bordered solve of [`super::bordered`]
//!     X ← orth(T X), FILTER_STEPS times from a spread start (subspace iteration)
//!     H = Vᵀ K V = Y Θ Yᵀ,  U = V Y,  r_i = P(K u_i − θ_i u_i)  (the p smallest Ritz pairs)
//!     V ← orth[V, T r_i for the r_i not converged]   (the first block: T X)
//!     converged when min(‖r_i‖, ‖R_C‖²/δ_C) ≤ tol_i, C θ_i's cluster (Kato–Temple)
//! ```
//! with tol_i from [`super::tolerances`] (RELATIVE_PRECISION of the largest reported |θ|). The
//! first factorization, at σ₀ = −negative_tolerance·g, counts the negative eigenvalues (the
//! verdict) and is the shift when there are none; otherwise σ steps down by 32× until the
//! count is 0. The subspace iteration damps the start's components along the upper spectrum
//! by (λ_wanted − σ)/(λ − σ) per step at the price of a block solve, so the Ritz basis starts
//! near the wanted space (the Krylov phase alone, from the spread start, grew to 65–76 vectors
//! on 345–1,563-dof films; after 8 filter steps 19–28). T r_i spans the same new direction as
//! T u_i (T r = u − (θ − σ) T u) without the cancellation against the converged part (measured:
//! T u_i stalled at residuals 1e-4·g on the double bubble). Rayleigh–Ritz on K itself keeps the
//! Ritz values upper bounds of the eigenvalues (Cauchy interlacing), so a second factorization
//! at c = θ_p + tol_p certifies that no eigenvalue below c was missed: its count must equal the
//! Ritz values below c. An uncertified result is `None` and the caller slices the spectrum
//! instead.

use nalgebra::{DMatrix, DMatrixView, DVector};
use nalgebra_sparse::{CooMatrix, CsrMatrix};

use super::bordered::{Bordered, gershgorin};
use super::{Spectrum, tolerances};
use crate::solver::kkt::KktError;

/// Ritz vectors kept beyond the wanted ones (guards the convergence of the last wanted).
const GUARD: usize = 4;

/// Ritz values closer than this (× g) are one cluster for the Kato–Temple bound.
const CLUSTER: f64 = 1e-6;

/// Subspace-iteration steps (T applied to the block, then orthonormalized) before the first
/// Rayleigh–Ritz: they damp the start's components along the upper spectrum cheaply (a block
/// solve and an orthonormalization each, no Ritz problem). Measured per analysis (least of 12
/// runs, load 5): 0 / 4 / 6 / 8 steps gave Ritz bases of 76 / 44 / 34 / 28 vectors on the
/// 648-facet double bubble (345 dofs), 65 / 35 / 26 / 20 on the 792-facet cube film and 68 /
/// 38 / 28 / 19 on the 3,042-facet double bubble.
const FILTER_STEPS: usize = 8;

/// Most block steps before giving up.
const MAX_STEPS: usize = 30;

/// Factor by which σ steps down while the count below it is positive.
const STEP_DOWN: f64 = 32.0;

/// Removes the components along the orthonormal `basis` (the projector P).
fn project(x: &mut DVector<f64>, basis: &[DVector<f64>]) {
    for b in basis {
        let c = b.dot(x);
        x.axpy(-c, b, 1.0);
    }
}

/// The `wanted` smallest eigenvalues of K (n×n, `entries` of both triangles) on the orthogonal
/// complement of the orthonormal `basis` within [`tolerances`], with their error bounds, and
/// how many lie below `−negative_tolerance·g` (g the Gershgorin bound); `None` when not
/// certified (module header).
pub(super) fn smallest(
    n: usize,
    entries: &[(usize, usize, f64)],
    basis: &[DVector<f64>],
    wanted: usize,
    negative_tolerance: f64,
) -> Result<Option<Spectrum>, KktError> {
    let g = gershgorin(n, entries);
    let mut bordered = Bordered::new(n, entries, basis)?;
    let free = n.saturating_sub(basis.len());
    let wanted = wanted.min(free);
    let negative = bordered.count(-negative_tolerance * g)?;
    if wanted == 0 {
        return Ok(Some(Spectrum {
            smallest: Vec::new(),
            errors: Vec::new(),
            negative,
        }));
    }
    if negative > 0 {
        let mut s = negative_tolerance * g;
        loop {
            s = (s * STEP_DOWN).min(1.01 * g);
            if bordered.count(-s)? == 0 {
                break;
            }
            if s >= 1.01 * g {
                return Ok(None);
            }
        }
    }
    let mut coo = CooMatrix::new(n, n);
    for &(i, j, v) in entries {
        coo.push(i, j, v);
    }
    let k = CsrMatrix::from(&coo);
    let block = (wanted + GUARD).min(free);
    // A deterministic spread start (Weyl sequence), projected.
    let start: Vec<f64> = (0..block)
        .flat_map(|j| {
            let mut x = DVector::from_fn(n, |i, _| {
                ((i * block + j + 1) as f64 * 0.618_033_988_749_895).fract() - 0.5
            });
            project(&mut x, basis);
            Vec::from(x.data)
        })
        .collect();
    // The basis V and K V, column-major n×m, grown a block at a time.
    let mut v: Vec<f64> = Vec::new();
    let mut kv: Vec<f64> = Vec::new();
    let mut h = DMatrix::zeros(0, 0);
    // The directions T is applied to (column-major n×·): the start, then the residuals not yet
    // converged.
    let mut directions = start;
    for _ in 0..FILTER_STEPS {
        bordered.solve(&mut directions);
        let mut filtered = Vec::with_capacity(directions.len());
        append_orthonormal(n, &directions, basis, &mut filtered, free);
        directions = filtered;
    }
    for _ in 0..MAX_STEPS {
        bordered.solve(&mut directions);
        let old = v.len() / n;
        append_orthonormal(n, &directions, basis, &mut v, free);
        let m = v.len() / n;
        if m == old {
            return Ok(None);
        }
        for column in v[old * n..].chunks_exact(n) {
            kv.extend((&k * DVector::from_column_slice(column)).iter());
        }
        let (all_v, all_kv) = (
            DMatrixView::from_slice(&v, n, m),
            DMatrixView::from_slice(&kv, n, m),
        );
        // H = Vᵀ K V, symmetrized, for the new columns.
        let v_kv_new = all_v.tr_mul(&all_kv.columns(old, m - old));
        let kv_v_new = all_kv.tr_mul(&all_v.columns(old, m - old));
        h = h.resize(m, m, 0.0);
        for j in old..m {
            for i in 0..=j {
                let e = 0.5 * (v_kv_new[(i, j - old)] + kv_v_new[(i, j - old)]);
                h[(i, j)] = e;
                h[(j, i)] = e;
            }
        }
        let eigen = h.clone().symmetric_eigen();
        let mut order: Vec<usize> = (0..m).collect();
        order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
        let theta: Vec<f64> = order.iter().map(|&i| eigen.eigenvalues[i]).collect();
        // Ritz vectors U = V Y and residuals P (K U − U Θ) of the `block` smallest.
        let kept = block.min(m);
        let y = DMatrix::from_fn(m, kept, |i, j| eigen.eigenvectors[(i, order[j])]);
        let u = all_v * &y;
        let ku = all_kv * &y;
        let residuals: Vec<DVector<f64>> = (0..kept)
            .map(|i| {
                let mut r: DVector<f64> = ku.column(i) - u.column(i) * theta[i];
                project(&mut r, basis);
                r
            })
            .collect();
        let norms: Vec<f64> = residuals.iter().map(|r| r.norm()).collect();
        let beyond = theta.get(kept).copied();
        let errors = error_bounds(&theta[..kept], &norms, beyond, CLUSTER * g);
        let tolerance = tolerances(&theta[..kept], wanted, g);
        let done: Vec<bool> = errors.iter().zip(&tolerance).map(|(e, t)| e <= t).collect();
        if m >= wanted && done[..wanted].iter().all(|&d| d) {
            let c = theta[wanted - 1] + tolerance[wanted - 1];
            let below = theta.iter().filter(|&&t| t < c).count();
            if bordered.count(c)? != below {
                return Ok(None);
            }
            return Ok(Some(Spectrum {
                smallest: theta[..wanted].to_vec(),
                errors: errors[..wanted].to_vec(),
                negative,
            }));
        }
        directions = residuals
            .iter()
            .zip(done)
            .filter(|(_, d)| !d)
            .flat_map(|(r, _)| r.iter().copied())
            .collect();
    }
    Ok(None)
}

/// Appends each column of `columns` (column-major, n rows) to the orthonormal column-major
/// n×m `v`: projected (P), orthogonalized against `v` by classical Gram–Schmidt twice and
/// normalized. A column that loses all but 1e-8 of its norm is dropped, and so is every column
/// once `v` has `limit` columns.
fn append_orthonormal(
    n: usize,
    columns: &[f64],
    basis: &[DVector<f64>],
    v: &mut Vec<f64>,
    limit: usize,
) {
    for column in columns.chunks_exact(n) {
        let mut x = DVector::from_column_slice(column);
        project(&mut x, basis);
        let before = x.norm();
        let m = v.len() / n;
        let basis_v = DMatrixView::from_slice(v, n, m);
        for _ in 0..2 {
            let c = basis_v.tr_mul(&x);
            x.gemv(-1.0, &basis_v, &c, 1.0);
        }
        let after = x.norm();
        if after > 1e-8 * before && m < limit {
            v.extend(x.iter().map(|e| e / after));
        }
    }
}

/// Error bounds of the ascending Ritz values `theta` (residual norms `norms`; `beyond` the next
/// Ritz value without a residual, if any): an eigenvalue lies within the residual norm of each,
/// and within the block Kato–Temple bound of its cluster when that is smaller. Consecutive
/// values closer than `join` form one cluster C; with ‖R_C‖ the Frobenius norm of its residuals
/// and δ its distance to the neighbouring clusters less their largest residual, the cluster's
/// eigenvalues lie within ‖R_C‖²/δ of its Ritz values (when δ > ‖R_C‖). A cluster at the top
/// with no `beyond` gets no gap bound.
fn error_bounds(theta: &[f64], norms: &[f64], beyond: Option<f64>, join: f64) -> Vec<f64> {
    let mut errors = norms.to_vec();
    let mut start = 0;
    while start < theta.len() {
        let mut end = start + 1;
        while end < theta.len() && theta[end] - theta[end - 1] < join {
            end += 1;
        }
        let below = (start > 0).then(|| theta[start - 1] + norms[start - 1]);
        let above = match theta.get(end) {
            Some(&t) => Some(t - norms[end]),
            None => beyond,
        };
        if let Some(above) = above {
            let spread = norms[start..end].iter().map(|r| r * r).sum::<f64>().sqrt();
            let gap = below.map_or(above - theta[end - 1], |b| {
                (theta[start] - b).min(above - theta[end - 1])
            });
            if gap > spread {
                let bound = spread * spread / gap;
                errors[start..end]
                    .iter_mut()
                    .for_each(|e| *e = e.min(bound));
            }
        }
        start = end;
    }
    errors
}

#[cfg(test)]
mod tests {
    use super::error_bounds;

    #[test]
    fn kato_temple_bounds_isolated_values_and_whole_clusters_but_not_an_open_top() {
        // 1.0 alone (gap 1 to the pair), the pair 2.0 / 2.0 + 1e-9 one cluster, 5.0 on top.
        let theta = [1.0, 2.0, 2.0 + 1e-9, 5.0];
        let norms = [1e-4, 1e-4, 1e-4, 1e-4];
        let errors = error_bounds(&theta, &norms, None, 1e-6);
        // r²/δ = 1e-8 / (1 − 1e-4) for 1.0; ‖R‖² = 2e-8 over δ = 2 − (1 + 1e-4) for the pair;
        // the top value keeps its residual.
        assert!(
            (errors[0] - 1e-8 / (1.0 - 1e-4)).abs() < 1e-20,
            "{errors:?}"
        );
        for e in &errors[1..3] {
            assert!((e - 2e-8 / (1.0 - 1e-4)).abs() < 1e-20, "{errors:?}");
        }
        assert_eq!(errors[3], 1e-4);
        // With the next Ritz value known the top one has a gap too: 1e-8 / 2.
        let errors = error_bounds(&theta, &norms, Some(7.0), 1e-6);
        assert!((errors[3] - 0.5e-8).abs() < 1e-20, "{errors:?}");
        // A residual larger than the gap gives no bound but the residuals themselves.
        let wide = [1e-4, 2.0, 2.0, 1e-9];
        assert_eq!(error_bounds(&theta, &wide, Some(9.0), 1e-6)[..3], wide[..3]);
    }
}
