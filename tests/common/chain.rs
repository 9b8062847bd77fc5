//! A hanging chain of equal links between (0, 0) and (1, 0): a sparse NLP of any size for
//! solver tests and medium-size benchmarks.
//!
//! Joint k (k = 1 … links−1) at (x, y) with unit mass: min Σ yₖ (potential energy, unit
//! gravity) s.t. |pₖ₊₁ − pₖ|² = ℓ² with ℓ = 1.5/links (total length 1.5); n = 2(links − 1),
//! m = links. The minimizer is symmetric about x = ½.

use optimize::solver::{Dims, EvalError, Nlp};

const INF: f64 = f64::INFINITY;

/// A hanging chain of `links` equal links between (0, 0) and (1, 0), total length 1.5, unit
/// masses at the interior joints: min Σ yᵢ s.t. |pₖ₊₁ − pₖ|² = ℓ². Sparse Jacobian (4 entries
/// per link, 2 at the ends) and a sparse Lagrangian Hessian with repeated diagonal entries
/// (duplicates are summed).
pub struct Chain {
    /// Number of links.
    pub links: usize,
    /// Whether the exact Lagrangian Hessian is offered.
    pub exact: bool,
}

impl Chain {
    fn joints(&self) -> usize {
        self.links - 1
    }
    fn length(&self) -> f64 {
        1.5 / self.links as f64
    }
    /// Position of joint k (0 and links are the fixed ends).
    /// Position of joint k (0 and links are the fixed ends).
    pub fn point(&self, x: &[f64], k: usize) -> (f64, f64) {
        if k == 0 {
            (0.0, 0.0)
        } else if k == self.links {
            (1.0, 0.0)
        } else {
            (x[2 * (k - 1)], x[2 * (k - 1) + 1])
        }
    }
    /// Variables (x, y) of joint k, if free.
    fn vars(&self, k: usize) -> Option<(usize, usize)> {
        (k > 0 && k < self.links).then(|| (2 * (k - 1), 2 * (k - 1) + 1))
    }
}

impl Nlp for Chain {
    fn dims(&self) -> Dims {
        let free_ends = 2 * (self.links - 2) + 2;
        Dims {
            n: 2 * self.joints(),
            m: self.links,
            jac_nnz: 2 * free_ends,
            hess_nnz: if self.exact {
                6 * (self.links - 2) + 4
            } else {
                0
            },
        }
    }
    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        xl.fill(-INF);
        xu.fill(INF);
        cl.fill(self.length().powi(2));
        cu.fill(self.length().powi(2));
    }
    fn start(&self, x: &mut [f64]) {
        // A V shape of the right length is feasible but far from optimal: start straight
        // and slightly sagging instead, which is infeasible (too short).
        for k in 1..self.links {
            let t = k as f64 / self.links as f64;
            x[2 * (k - 1)] = t;
            x[2 * (k - 1) + 1] = -0.1 * (std::f64::consts::PI * t).sin();
        }
    }
    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut e = 0;
        for k in 0..self.links {
            for joint in [k, k + 1] {
                if let Some((vx, vy)) = self.vars(joint) {
                    rows[e] = k;
                    cols[e] = vx;
                    rows[e + 1] = k;
                    cols[e + 1] = vy;
                    e += 2;
                }
            }
        }
    }
    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        *f = (1..self.links).map(|k| self.point(x, k).1).sum();
        for (k, ck) in c.iter_mut().enumerate() {
            let (a, b) = (self.point(x, k), self.point(x, k + 1));
            *ck = (b.0 - a.0).powi(2) + (b.1 - a.1).powi(2);
        }
        Ok(())
    }
    fn eval_derivatives(&self, x: &[f64], g: &mut [f64], jac: &mut [f64]) -> Result<(), EvalError> {
        for k in 0..self.joints() {
            g[2 * k] = 0.0;
            g[2 * k + 1] = 1.0;
        }
        let mut e = 0;
        for k in 0..self.links {
            let (a, b) = (self.point(x, k), self.point(x, k + 1));
            for (joint, sign) in [(k, -1.0), (k + 1, 1.0)] {
                if self.vars(joint).is_some() {
                    jac[e] = sign * 2.0 * (b.0 - a.0);
                    jac[e + 1] = sign * 2.0 * (b.1 - a.1);
                    e += 2;
                }
            }
        }
        Ok(())
    }
    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        let mut e = 0;
        for k in 0..self.links {
            let (a, b) = (self.vars(k), self.vars(k + 1));
            for v in [a, b].into_iter().flatten() {
                rows[e] = v.0;
                cols[e] = v.0;
                rows[e + 1] = v.1;
                cols[e + 1] = v.1;
                e += 2;
            }
            if let (Some(a), Some(b)) = (a, b) {
                rows[e] = b.0;
                cols[e] = a.0;
                rows[e + 1] = b.1;
                cols[e + 1] = a.1;
                e += 2;
            }
        }
    }
    fn eval_hessian(
        &self,
        _x: &[f64],
        _sigma: f64,
        lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        let mut e = 0;
        for (k, &l) in lambda.iter().enumerate() {
            let (a, b) = (self.vars(k), self.vars(k + 1));
            for _ in [a, b].into_iter().flatten() {
                values[e] = 2.0 * l;
                values[e + 1] = 2.0 * l;
                e += 2;
            }
            if a.is_some() && b.is_some() {
                values[e] = -2.0 * l;
                values[e + 1] = -2.0 * l;
                e += 2;
            }
        }
        Ok(())
    }
}
