//! Limited-memory BFGS in compact form (Byrd, Nocedal & Schnabel, Math. Prog. 63, 1994, eq. 2.17):
//!
//! ```text
//!     B = δI − W M Wᵀ,   W = [δS  Y] (n×2p),   M = [δSᵀS  L; Lᵀ  −D]⁻¹ (2p×2p)
//! ```
//! with S, Y the last p (Powell-damped) pairs, L the strictly lower part of SᵀY, D its diagonal
//! and δ = yᵀy/sᵀy of the newest pair. Damping uses `B s` computed from the compact form.
//! Memory O(n p); no n×n matrix is ever formed.

use nalgebra::{DMatrix, DVector};

use super::powell_damped;

/// A limited-memory quasi-Newton model of the Lagrangian Hessian.
#[derive(Debug, Clone)]
pub struct Lbfgs {
    n: usize,
    memory: usize,
    s: Vec<DVector<f64>>,
    y: Vec<DVector<f64>>,
    delta: f64,
    w: DMatrix<f64>,
    m: DMatrix<f64>,
}

impl Lbfgs {
    /// Empty model (B = I) for n variables keeping `memory` pairs (at least 1).
    pub fn new(n: usize, memory: usize) -> Self {
        Lbfgs {
            n,
            memory: memory.max(1),
            s: Vec::new(),
            y: Vec::new(),
            delta: 1.0,
            w: DMatrix::zeros(n, 0),
            m: DMatrix::zeros(0, 0),
        }
    }

    /// Forgets all pairs.
    pub fn reset(&mut self) {
        *self = Lbfgs::new(self.n, self.memory);
    }

    /// (δ, W, M) of the compact form.
    pub fn compact(&self) -> (f64, &DMatrix<f64>, &DMatrix<f64>) {
        (self.delta, &self.w, &self.m)
    }

    /// B·v from the compact form.
    pub fn times(&self, v: &DVector<f64>) -> DVector<f64> {
        let wtv = self.w.tr_mul(v);
        v * self.delta - &self.w * (&self.m * wtv)
    }

    /// Adds the pair (s, y) after Powell damping; skips negligible or non-finite pairs.
    pub fn update(&mut self, s: &[f64], y: &[f64]) {
        let sv = DVector::from_column_slice(s);
        if sv.norm() == 0.0 || !y.iter().all(|v| v.is_finite()) {
            return;
        }
        let bs = self.times(&sv);
        let sbs = sv.dot(&bs);
        if sbs <= 0.0 {
            return;
        }
        let yv = DVector::from_vec(powell_damped(s, y, bs.as_slice(), sbs));
        let sy = sv.dot(&yv);
        if sy <= 1e-14 * sbs {
            return;
        }
        if self.s.len() == self.memory {
            self.s.remove(0);
            self.y.remove(0);
        }
        self.delta = (yv.norm_squared() / sy).clamp(1e-8, 1e8);
        self.s.push(sv);
        self.y.push(yv);
        self.rebuild();
    }

    fn rebuild(&mut self) {
        let p = self.s.len();
        let mut w = DMatrix::zeros(self.n, 2 * p);
        for k in 0..p {
            w.set_column(k, &(&self.s[k] * self.delta));
            w.set_column(p + k, &self.y[k]);
        }
        let mut middle = DMatrix::zeros(2 * p, 2 * p);
        for i in 0..p {
            for j in 0..p {
                middle[(i, j)] = self.delta * self.s[i].dot(&self.s[j]);
            }
            for j in 0..i {
                let l = self.s[i].dot(&self.y[j]);
                middle[(i, p + j)] = l;
                middle[(p + j, i)] = l;
            }
            middle[(p + i, p + i)] = -self.s[i].dot(&self.y[i]);
        }
        match middle.try_inverse() {
            Some(m) => {
                self.w = w;
                self.m = m;
            }
            None => self.reset(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compact_form_equals_dense_bfgs_from_scaled_identity() {
        // With δ fixed by the newest pair, the compact form is BFGS started from δI; compare
        // against dense BFGS recursions started from the same δI.
        // Pairs y = A s of a positive definite A with eigenvalues near 1: no damping occurs.
        let a = DMatrix::from_row_slice(
            4,
            4,
            &[
                1.2, 0.1, 0.0, 0.05, 0.1, 1.0, 0.1, 0.0, 0.0, 0.1, 0.9, 0.1, 0.05, 0.0, 0.1, 1.1,
            ],
        );
        let steps = [
            [1.0, 0.2, 0.0, -0.3],
            [0.0, 1.0, 0.5, 0.1],
            [0.3, -0.2, 1.0, 0.4],
        ];
        let pairs: Vec<([f64; 4], [f64; 4])> = steps
            .iter()
            .map(|s| {
                let y = &a * DVector::from_column_slice(s);
                (*s, [y[0], y[1], y[2], y[3]])
            })
            .collect();
        let mut l = Lbfgs::new(4, 5);
        for (s, y) in &pairs {
            l.update(s, y);
        }
        let (delta, w, m) = l.compact();
        let compact = DMatrix::identity(4, 4) * delta - w * m * w.transpose();
        let mut dense = DMatrix::identity(4, 4) * delta;
        for (s, y) in &pairs {
            let s = DVector::from_column_slice(s);
            let y = DVector::from_column_slice(y);
            let bs = &dense * &s;
            let sbs = s.dot(&bs);
            dense.ger(-1.0 / sbs, &bs, &bs, 1.0);
            dense.ger(1.0 / s.dot(&y), &y, &y, 1.0);
        }
        assert!((compact - dense).amax() < 1e-10);
    }
}
