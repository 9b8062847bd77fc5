//! Products with the QP data: `H x` in each Hessian representation, `A x` and `Aᵀ y`.
//!
//! `SparseLower` stores one triangle; each off-diagonal entry (r, c) stands for both H_rc and
//! H_cr. `LowRank` applies `δx − W(M(Wᵀx))` with two length-p temporaries, never forming n×n.

use nalgebra_sparse::CsrMatrix;

use crate::solver::qp::QpHessian;

/// `y ← H x`. `tmp` must have length ≥ 2p for the low-rank form (unused otherwise).
pub fn hessian_times(h: &QpHessian<'_>, x: &[f64], y: &mut [f64], tmp: &mut [f64]) {
    match *h {
        QpHessian::Dense(dense) => {
            let n = x.len();
            for (i, yi) in y.iter_mut().enumerate() {
                let mut acc = 0.0;
                for (j, xj) in x.iter().enumerate().take(n) {
                    acc += dense[(i, j)] * xj;
                }
                *yi = acc;
            }
        }
        QpHessian::SparseLower(lower) => {
            y.fill(0.0);
            let (offsets, rows, values) = lower.csc_data();
            for c in 0..x.len() {
                for p in offsets[c]..offsets[c + 1] {
                    let (r, v) = (rows[p], values[p]);
                    y[r] += v * x[c];
                    if r != c {
                        y[c] += v * x[r];
                    }
                }
            }
        }
        QpHessian::LowRank { delta, w, m } => {
            let p = w.ncols();
            let (wtx, mwtx) = tmp[..2 * p].split_at_mut(p);
            for (k, slot) in wtx.iter_mut().enumerate() {
                *slot = dot(w.column(k).as_slice(), x);
            }
            for (i, slot) in mwtx.iter_mut().enumerate() {
                *slot = (0..p).map(|k| m[(i, k)] * wtx[k]).sum();
            }
            for (yi, xi) in y.iter_mut().zip(x) {
                *yi = delta * xi;
            }
            for (k, coefficient) in mwtx.iter().enumerate() {
                for (yi, wi) in y.iter_mut().zip(w.column(k).iter()) {
                    *yi -= coefficient * wi;
                }
            }
        }
    }
}

/// `y ← A x`.
pub fn a_times(a: &CsrMatrix<f64>, x: &[f64], y: &mut [f64]) {
    let (offsets, cols, values) = a.csr_data();
    for (i, yi) in y.iter_mut().enumerate() {
        *yi = (offsets[i]..offsets[i + 1])
            .map(|p| values[p] * x[cols[p]])
            .sum();
    }
}

/// `x ← Aᵀ y`.
pub fn a_transpose_times(a: &CsrMatrix<f64>, y: &[f64], x: &mut [f64]) {
    x.fill(0.0);
    let (offsets, cols, values) = a.csr_data();
    for (i, yi) in y.iter().enumerate() {
        for p in offsets[i]..offsets[i + 1] {
            x[cols[p]] += values[p] * yi;
        }
    }
}

/// ‖v‖∞.
pub fn inf_norm(v: &[f64]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// vᵀw.
pub fn dot(v: &[f64], w: &[f64]) -> f64 {
    v.iter().zip(w).map(|(a, b)| a * b).sum()
}
