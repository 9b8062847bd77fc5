//! Dense damped BFGS: `B⁺ = B − (Bs)(Bs)ᵀ/(sᵀBs) + yyᵀ/(sᵀy)` with Powell's damping of y.
//! The first update rescales the identity to `(yᵀy/sᵀy)·I` (Nocedal & Wright, eq. 6.20).

use nalgebra::{DMatrix, DVector};

use super::powell_damped;

/// A dense positive definite approximation of the Lagrangian Hessian.
#[derive(Debug, Clone)]
pub struct DenseBfgs {
    b: DMatrix<f64>,
    fresh: bool,
}

impl DenseBfgs {
    /// Identity of size n.
    pub fn new(n: usize) -> Self {
        DenseBfgs {
            b: DMatrix::identity(n, n),
            fresh: true,
        }
    }

    /// The current matrix.
    pub fn matrix(&self) -> &DMatrix<f64> {
        &self.b
    }

    /// Back to the identity (after a failed line search).
    pub fn reset(&mut self) {
        self.b.fill_with_identity();
        self.fresh = true;
    }

    /// Updates with step `s` and Lagrangian-gradient change `y`; skips negligible steps.
    pub fn update(&mut self, s: &[f64], y: &[f64]) {
        let sv = DVector::from_column_slice(s);
        let ss = sv.norm_squared();
        if ss == 0.0 || !y.iter().all(|v| v.is_finite()) {
            return;
        }
        if self.fresh {
            let yv = DVector::from_column_slice(y);
            let sy = sv.dot(&yv);
            if sy > 1e-12 * ss.sqrt() * yv.norm() {
                let scale = (yv.norm_squared() / sy).clamp(1e-6, 1e6);
                self.b.fill_with_identity();
                self.b *= scale;
            }
            self.fresh = false;
        }
        let bs = &self.b * &sv;
        let sbs = sv.dot(&bs);
        if sbs <= 0.0 {
            return;
        }
        let y = DVector::from_vec(powell_damped(s, y, bs.as_slice(), sbs));
        let sy = sv.dot(&y);
        if sy <= 1e-14 * sbs {
            return;
        }
        self.b.ger(-1.0 / sbs, &bs, &bs, 1.0);
        self.b.ger(1.0 / sy, &y, &y, 1.0);
        // Keep exact symmetry against rounding.
        let n = self.b.nrows();
        for i in 0..n {
            for j in 0..i {
                let v = 0.5 * (self.b[(i, j)] + self.b[(j, i)]);
                self.b[(i, j)] = v;
                self.b[(j, i)] = v;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn secant_condition_holds_and_stays_positive_definite() {
        let mut b = DenseBfgs::new(3);
        let steps = [
            ([1.0, 0.0, 0.5], [2.0, 0.1, 1.0]),
            ([0.0, 1.0, -0.2], [0.3, 3.0, -0.1]),
            ([0.4, -0.3, 1.0], [-1.0, 0.2, -0.5]), // negative curvature: damped
        ];
        for (k, (s, y)) in steps.iter().enumerate() {
            b.update(s, y);
            let bs = b.matrix() * DVector::from_column_slice(s);
            if k < 2 {
                for i in 0..3 {
                    assert!((bs[i] - y[i]).abs() < 1e-10, "secant condition");
                }
            }
            assert!(b.matrix().clone().cholesky().is_some());
        }
    }
}
