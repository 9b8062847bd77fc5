//! Second-order forward-mode numbers of a fixed small dimension N: a value with its exact
//! gradient and Hessian w.r.t. N seed variables, propagated through +, −, ×, ÷ and √.
//!
//! ```text
//!   (a·b)'' = a'' b + a b'' + a' ⊗ b' + b' ⊗ a'
//!   (a/b)'  = (a' − q b') / b,          q = a/b
//!   (a/b)'' = (a'' − q b'' − q' ⊗ b' − b' ⊗ q') / b
//!   (√a)'   = a' / (2s),                s = √a
//!   (√a)''  = (a'' − 2 s' ⊗ s') / (2s)
//! ```
//! Only the lower triangle (row ≥ column) of the Hessian is propagated; [`Hyper::hessian`]
//! mirrors it. A plain `Copy` struct of arrays: no allocation and no branches per operation,
//! which is what the curvature Hessian's hundreds of thousands of small evaluations need
//! (num-dual's `Dual2SVec64` carries full optional matrices and spent most of its time
//! copying them).

use std::ops::{Add, Div, Mul, Sub};

/// A value with its gradient and (lower-triangle) Hessian w.r.t. N seed variables.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hyper<const N: usize> {
    /// The value.
    pub re: f64,
    /// ∂/∂x_i.
    pub grad: [f64; N],
    /// ∂²/∂x_i∂x_j for j ≤ i (entries above the diagonal are not kept up to date).
    lower: [[f64; N]; N],
}

impl<const N: usize> Hyper<N> {
    /// A constant (zero derivatives).
    pub fn constant(re: f64) -> Self {
        Hyper {
            re,
            grad: [0.0; N],
            lower: [[0.0; N]; N],
        }
    }

    /// Seed variable `i` with value `re`.
    pub fn variable(re: f64, i: usize) -> Self {
        let mut v = Self::constant(re);
        v.grad[i] = 1.0;
        v
    }

    /// The full symmetric Hessian.
    pub fn hessian(&self) -> [[f64; N]; N] {
        std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                if j <= i {
                    self.lower[i][j]
                } else {
                    self.lower[j][i]
                }
            })
        })
    }

    /// √self (self.re > 0 for finite derivatives).
    pub fn sqrt(self) -> Self {
        let s = self.re.sqrt();
        let half_inv = 0.5 / s;
        let mut out = Self::constant(s);
        for i in 0..N {
            out.grad[i] = self.grad[i] * half_inv;
        }
        for i in 0..N {
            for j in 0..=i {
                out.lower[i][j] = (self.lower[i][j] - 2.0 * out.grad[i] * out.grad[j]) * half_inv;
            }
        }
        out
    }
}

impl<const N: usize> Add for Hyper<N> {
    type Output = Self;
    fn add(mut self, b: Self) -> Self {
        self.re += b.re;
        for i in 0..N {
            self.grad[i] += b.grad[i];
            for j in 0..=i {
                self.lower[i][j] += b.lower[i][j];
            }
        }
        self
    }
}

impl<const N: usize> Sub for Hyper<N> {
    type Output = Self;
    fn sub(mut self, b: Self) -> Self {
        self.re -= b.re;
        for i in 0..N {
            self.grad[i] -= b.grad[i];
            for j in 0..=i {
                self.lower[i][j] -= b.lower[i][j];
            }
        }
        self
    }
}

impl<const N: usize> Mul for Hyper<N> {
    type Output = Self;
    fn mul(self, b: Self) -> Self {
        let mut out = Self::constant(self.re * b.re);
        for i in 0..N {
            out.grad[i] = self.re * b.grad[i] + b.re * self.grad[i];
            for j in 0..=i {
                out.lower[i][j] = self.re * b.lower[i][j]
                    + b.re * self.lower[i][j]
                    + self.grad[i] * b.grad[j]
                    + b.grad[i] * self.grad[j];
            }
        }
        out
    }
}

impl<const N: usize> Mul<f64> for Hyper<N> {
    type Output = Self;
    fn mul(mut self, k: f64) -> Self {
        self.re *= k;
        for i in 0..N {
            self.grad[i] *= k;
            for j in 0..=i {
                self.lower[i][j] *= k;
            }
        }
        self
    }
}

impl<const N: usize> Div for Hyper<N> {
    type Output = Self;
    fn div(self, b: Self) -> Self {
        let inv = 1.0 / b.re;
        let q = self.re * inv;
        let mut out = Self::constant(q);
        for i in 0..N {
            out.grad[i] = (self.grad[i] - q * b.grad[i]) * inv;
        }
        for i in 0..N {
            for j in 0..=i {
                out.lower[i][j] = (self.lower[i][j]
                    - q * b.lower[i][j]
                    - out.grad[i] * b.grad[j]
                    - b.grad[i] * out.grad[j])
                    * inv;
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// f(x, y, z) = x·y / √(x² + y² + z²) − 1.5 z/(x + 2): the value against plain
    /// arithmetic, the gradient and Hessian against central differences of the value and of
    /// the gradient.
    #[test]
    fn derivatives_match_central_differences() {
        let f = |v: [Hyper<3>; 3]| {
            let [x, y, z] = v;
            let r = (x * x + y * y + z * z).sqrt();
            x * y / r - z / (x + Hyper::constant(2.0)) * 1.5
        };
        let eval = |p: [f64; 3]| f([0, 1, 2].map(|i| Hyper::variable(p[i], i)));
        let p = [0.7, -1.3, 0.4];
        let at = eval(p);
        let plain = {
            let [x, y, z] = p;
            x * y / (x * x + y * y + z * z).sqrt() - 1.5 * z / (x + 2.0)
        };
        assert!((at.re - plain).abs() < 1e-15);
        let h = 1e-6;
        for k in 0..3 {
            let shifted = |d: f64| {
                let mut q = p;
                q[k] += d;
                eval(q)
            };
            let (plus, minus) = (shifted(h), shifted(-h));
            assert!((at.grad[k] - (plus.re - minus.re) / (2.0 * h)).abs() < 1e-8);
            for i in 0..3 {
                let fd = (plus.grad[i] - minus.grad[i]) / (2.0 * h);
                assert!((at.hessian()[i][k] - fd).abs() < 1e-7, "{i} {k}");
            }
        }
    }
}
