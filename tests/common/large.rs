//! A generated large sparse NLP with a known solution, for scale tests and benches.
//!
//! Chained Rosenbrock objective with chained trigonometric–exponential equality constraints
//! (after Lukšan & Vlček, "Sparse and partially separable test problems for unconstrained and
//! equality constrained optimization", TR 767, ICS Prague 1999, problem 5.1), turned into a
//! problem with a *manufactured* KKT point:
//! ```text
//!     min  f(x) = Σ_{i=0}^{n−2} [100 (x_{i+1} − x_i²)² + (1 − x_i)²] + qᵀx
//!     s.t. φ(x_{j_k}, x_{j_k+1}, x_{j_k+2}) = φ(x*_{j_k}, x*_{j_k+1}, x*_{j_k+2}),  k < m
//!          −5 ≤ x ≤ 5,   x_j ≤ x*_j for j ≡ 3 (mod 7)
//!     φ(a, b, c) = 3b³ + 2c − 5 + sin(b − c) sin(b + c) + 4b − a e^{a−b} − 3
//! ```
//! with m = ⌊2n/5⌋ constraints on the triples starting at j_k = ⌊5k/2⌋ (all constraints are
//! nonlinear; their Jacobian has full row rank because column j_k + 1 appears only in row k).
//! The point x*_j = 1 + 0.1 sin(j), multipliers λ*_k = 0.5 cos(k) and bound multipliers
//! z*_j = 1 + 0.5 sin²(j) on the active upper bounds are chosen first, then
//! q = −∇f₀(x*) − J(x*)ᵀλ* − z* makes them satisfy `∇f(x*) + J(x*)ᵀλ* + z* = 0` exactly
//! (the QP's sign convention: z ≥ 0 at an active upper bound). Second-order sufficiency is
//! checked numerically in the tests at small sizes.
//!
//! The exact Lagrangian Hessian `σ∇²f + Σ λ_k ∇²c_k` has the pattern of a tridiagonal matrix
//! (diagonal + first subdiagonal), lower triangle. The start is x⁰ = x* − 0.5 (infeasible).

use nalgebra_sparse::{CooMatrix, CscMatrix, CsrMatrix};
use optimize::solver::{Dims, EvalError, Nlp};

/// The generated problem of size n (see the module header).
pub struct ChainedRosenbrock {
    n: usize,
    m: usize,
    x_star: Vec<f64>,
    lambda_star: Vec<f64>,
    z_star: Vec<f64>,
    /// Linear term q of the objective.
    q: Vec<f64>,
    /// Right-hand side φ(x*) of each constraint.
    rhs: Vec<f64>,
}

/// First index of constraint k's triple.
fn triple_start(k: usize) -> usize {
    5 * k / 2
}

/// φ(a, b, c) and its gradient and Hessian (aa, ab, bb, cc; ac = bc = 0).
/// sin(b − c) sin(b + c) is evaluated as (cos 2c − cos 2b)/2.
fn phi(a: f64, b: f64, c: f64) -> (f64, [f64; 3], [f64; 4]) {
    let e = (a - b).exp();
    let value =
        3.0 * b.powi(3) + 2.0 * c - 5.0 + 0.5 * ((2.0 * c).cos() - (2.0 * b).cos()) + 4.0 * b
            - a * e
            - 3.0;
    let grad = [
        -(1.0 + a) * e,
        9.0 * b * b + 4.0 + (2.0 * b).sin() + a * e,
        2.0 - (2.0 * c).sin(),
    ];
    let hess = [
        -(2.0 + a) * e,
        (1.0 + a) * e,
        18.0 * b + 2.0 * (2.0 * b).cos() - a * e,
        -2.0 * (2.0 * c).cos(),
    ];
    (value, grad, hess)
}

/// Chained Rosenbrock f₀ and its gradient.
fn rosenbrock(x: &[f64], grad: &mut [f64]) -> f64 {
    grad.fill(0.0);
    let mut f = 0.0;
    for i in 0..x.len() - 1 {
        let r = x[i + 1] - x[i] * x[i];
        f += 100.0 * r * r + (1.0 - x[i]) * (1.0 - x[i]);
        grad[i] += -400.0 * x[i] * r - 2.0 * (1.0 - x[i]);
        grad[i + 1] += 200.0 * r;
    }
    f
}

impl ChainedRosenbrock {
    /// The problem with `n ≥ 5` variables and ⌊2n/5⌋ constraints.
    pub fn new(n: usize) -> Self {
        assert!(n >= 5, "the chained problem needs at least 5 variables");
        let m = 2 * n / 5;
        let x_star: Vec<f64> = (0..n).map(|j| 1.0 + 0.1 * (j as f64).sin()).collect();
        let lambda_star: Vec<f64> = (0..m).map(|k| 0.5 * (k as f64).cos()).collect();
        let z_star: Vec<f64> = (0..n)
            .map(|j| {
                if j % 7 == 3 {
                    1.0 + 0.5 * (j as f64).sin().powi(2)
                } else {
                    0.0
                }
            })
            .collect();
        let mut q = vec![0.0; n];
        rosenbrock(&x_star, &mut q);
        let mut rhs = Vec::with_capacity(m);
        for (k, lambda) in lambda_star.iter().enumerate() {
            let j = triple_start(k);
            let (value, grad, _) = phi(x_star[j], x_star[j + 1], x_star[j + 2]);
            rhs.push(value);
            for (t, g) in grad.iter().enumerate() {
                q[j + t] += lambda * g;
            }
        }
        for (qj, zj) in q.iter_mut().zip(&z_star) {
            *qj = -(*qj + zj);
        }
        ChainedRosenbrock {
            n,
            m,
            x_star,
            lambda_star,
            z_star,
            q,
            rhs,
        }
    }

    /// The manufactured solution x*.
    pub fn solution(&self) -> &[f64] {
        &self.x_star
    }

    /// Constraint multipliers λ* at x* (convention ∇f + Jᵀλ + z = 0).
    pub fn multipliers(&self) -> &[f64] {
        &self.lambda_star
    }

    /// Bound multipliers z* at x* (≥ 0 at the active upper bounds, 0 elsewhere).
    pub fn bound_multipliers(&self) -> &[f64] {
        &self.z_star
    }

    /// The objective value f(x*).
    pub fn optimal_objective(&self) -> f64 {
        let mut f = 0.0;
        let mut c = vec![0.0; self.m];
        self.eval(&self.x_star, &mut f, &mut c)
            .expect("x* is in the domain");
        f
    }

    /// The first SQP subproblem at the start x⁰: H = ∇²L(x⁰, λ = 0, σ = 1) (exact, lower
    /// triangle; indefinite in general), A = J(x⁰), g = ∇f(x⁰), and the bounds shifted by x⁰.
    pub fn first_qp(&self) -> FirstQp {
        let dims = self.dims();
        let (n, m) = (dims.n, dims.m);
        let mut x = vec![0.0; n];
        self.start(&mut x);
        let (mut xl, mut xu, mut cl, mut cu) =
            (vec![0.0; n], vec![0.0; n], vec![0.0; m], vec![0.0; m]);
        self.bounds(&mut xl, &mut xu, &mut cl, &mut cu);
        let mut f = 0.0;
        let mut c = vec![0.0; m];
        self.eval(&x, &mut f, &mut c)
            .expect("the start is in the domain");
        let mut g = vec![0.0; n];
        let mut jac = vec![0.0; dims.jac_nnz];
        self.eval_derivatives(&x, &mut g, &mut jac)
            .expect("the start is in the domain");
        let (mut jr, mut jc) = (vec![0; dims.jac_nnz], vec![0; dims.jac_nnz]);
        self.jacobian_structure(&mut jr, &mut jc);
        let a = CsrMatrix::from(
            &CooMatrix::try_from_triplets(m, n, jr, jc, jac).expect("valid Jacobian pattern"),
        );
        let (mut hr, mut hc) = (vec![0; dims.hess_nnz], vec![0; dims.hess_nnz]);
        self.hessian_structure(&mut hr, &mut hc);
        let mut hv = vec![0.0; dims.hess_nnz];
        self.eval_hessian(&x, 1.0, &vec![0.0; m], &mut hv)
            .expect("the start is in the domain");
        let h = CscMatrix::from(
            &CooMatrix::try_from_triplets(n, n, hr, hc, hv).expect("valid Hessian pattern"),
        );
        FirstQp {
            dl: xl.iter().zip(&x).map(|(l, x)| l - x).collect(),
            du: xu.iter().zip(&x).map(|(u, x)| u - x).collect(),
            bl: cl.iter().zip(&c).map(|(l, c)| l - c).collect(),
            bu: cu.iter().zip(&c).map(|(u, c)| u - c).collect(),
            h,
            g,
            a,
        }
    }
}

/// Owned data of a QP subproblem (see `optimize::solver::qp::QpProblem`).
pub struct FirstQp {
    /// Hessian, lower triangle.
    pub h: CscMatrix<f64>,
    /// Gradient.
    pub g: Vec<f64>,
    /// Constraint Jacobian.
    pub a: CsrMatrix<f64>,
    /// Step bounds.
    pub dl: Vec<f64>,
    /// Step bounds.
    pub du: Vec<f64>,
    /// Linearized constraint bounds.
    pub bl: Vec<f64>,
    /// Linearized constraint bounds.
    pub bu: Vec<f64>,
}

impl Nlp for ChainedRosenbrock {
    fn dims(&self) -> Dims {
        Dims {
            n: self.n,
            m: self.m,
            jac_nnz: 3 * self.m,
            hess_nnz: 2 * self.n - 1,
        }
    }

    fn bounds(&self, xl: &mut [f64], xu: &mut [f64], cl: &mut [f64], cu: &mut [f64]) {
        for j in 0..self.n {
            xl[j] = -5.0;
            xu[j] = if self.z_star[j] > 0.0 {
                self.x_star[j]
            } else {
                5.0
            };
        }
        cl.copy_from_slice(&self.rhs);
        cu.copy_from_slice(&self.rhs);
    }

    fn start(&self, x: &mut [f64]) {
        for (xj, sj) in x.iter_mut().zip(&self.x_star) {
            *xj = sj - 0.5;
        }
    }

    fn jacobian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for k in 0..self.m {
            for t in 0..3 {
                rows[3 * k + t] = k;
                cols[3 * k + t] = triple_start(k) + t;
            }
        }
    }

    fn eval(&self, x: &[f64], f: &mut f64, c: &mut [f64]) -> Result<(), EvalError> {
        let mut scratch = vec![0.0; self.n];
        *f = rosenbrock(x, &mut scratch) + self.q.iter().zip(x).map(|(q, x)| q * x).sum::<f64>();
        for (k, ck) in c.iter_mut().enumerate() {
            let j = triple_start(k);
            *ck = phi(x[j], x[j + 1], x[j + 2]).0;
        }
        if f.is_finite() && c.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(EvalError::Domain(
                "overflow in the chained functions".into(),
            ))
        }
    }

    fn eval_derivatives(
        &self,
        x: &[f64],
        grad: &mut [f64],
        jac: &mut [f64],
    ) -> Result<(), EvalError> {
        rosenbrock(x, grad);
        for (g, q) in grad.iter_mut().zip(&self.q) {
            *g += q;
        }
        for k in 0..self.m {
            let j = triple_start(k);
            let (_, g, _) = phi(x[j], x[j + 1], x[j + 2]);
            jac[3 * k..3 * k + 3].copy_from_slice(&g);
        }
        if grad.iter().chain(jac.iter()).all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(EvalError::Domain(
                "overflow in the chained derivatives".into(),
            ))
        }
    }

    /// Diagonal entries first (j, j), then the subdiagonal (j + 1, j).
    fn hessian_structure(&self, rows: &mut [usize], cols: &mut [usize]) {
        for j in 0..self.n {
            rows[j] = j;
            cols[j] = j;
        }
        for j in 0..self.n - 1 {
            rows[self.n + j] = j + 1;
            cols[self.n + j] = j;
        }
    }

    fn eval_hessian(
        &self,
        x: &[f64],
        sigma: f64,
        lambda: &[f64],
        values: &mut [f64],
    ) -> Result<(), EvalError> {
        let n = self.n;
        values.fill(0.0);
        let (diag, sub) = values.split_at_mut(n);
        for i in 0..n - 1 {
            diag[i] += sigma * (1200.0 * x[i] * x[i] - 400.0 * x[i + 1] + 2.0);
            diag[i + 1] += sigma * 200.0;
            sub[i] += sigma * (-400.0 * x[i]);
        }
        for (k, lk) in lambda.iter().enumerate() {
            let j = triple_start(k);
            let (_, _, h) = phi(x[j], x[j + 1], x[j + 2]);
            diag[j] += lk * h[0];
            sub[j] += lk * h[1];
            diag[j + 1] += lk * h[2];
            diag[j + 2] += lk * h[3];
        }
        if values.iter().all(|v| v.is_finite()) {
            Ok(())
        } else {
            Err(EvalError::Domain("overflow in the chained Hessian".into()))
        }
    }

    fn constraint_name(&self, row: usize) -> String {
        format!("chain[{row}]")
    }
}
